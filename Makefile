# Two commands on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

NODE_DIR := tests/interop/node
NODE_STAMP := $(NODE_DIR)/node_modules/.installed

.PHONY: run test lint typecheck unit bench clean tools core

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,plot,cluster]'
	touch $(STAMP)

# The GEO cycle's modules, simulate's per-cycle part and the GEO loop compiled with mypyc
# (liftd.cnc.COMPILED, liftd.sim.COMPILED, liftd.runtime.COMPILED), rebuilt when one changes;
# without a C compiler the core runs as Python (the script says so and exits 0).
CORE_LISTS := liftd/cnc/__init__.py liftd/sim/__init__.py liftd/runtime/__init__.py
CORE_SRC   := $(shell $(PYTHON) -c "import ast,sys; print(' '.join(v.value.replace('.','/')+'.py' for f in sys.argv[1:] for n in ast.parse(open(f).read()).body if isinstance(n,ast.AnnAssign) for v in n.value.elts))" $(CORE_LISTS))
CORE_STAMP := build/mypyc/.compiled

$(CORE_STAMP): $(STAMP) $(CORE_SRC) $(CORE_LISTS) tools/compile_core.py
	$(BIN)/python tools/compile_core.py
	@mkdir -p $(dir $@) && touch $@

# always compiles (e.g. after installing a compiler)
core: $(STAMP)
	$(BIN)/python tools/compile_core.py
	@mkdir -p $(dir $(CORE_STAMP)) && touch $(CORE_STAMP)

run: $(STAMP) $(CORE_STAMP)
	$(BIN)/liftd run

# The interop tests' independent clients: Node ads-client from the committed lockfile, and
# Debian's tshark (Wireshark's AMS dissector) when missing and we are root; the live view's
# browser tests: Debian's chromium (Playwright drives /usr/bin/chromium; `playwright install`
# is never run). Quick when present.
$(NODE_STAMP): $(NODE_DIR)/package-lock.json
	@command -v npm >/dev/null || { echo "npm missing: the Node interop tests will fail"; exit 0; }; \
	  cd $(NODE_DIR) && npm ci --no-audit --no-fund --silent && touch node_modules/.installed

tools: $(NODE_STAMP)
	@command -v tshark >/dev/null || { [ "$$(id -u)" = 0 ] && \
	  { DEBIAN_FRONTEND=noninteractive apt-get install -y -qq tshark >/dev/null 2>&1 || \
	    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq tshark >/dev/null; }; }; } || \
	  echo "tshark missing and not root: the Wireshark interop test is skipped"
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && \
	  { DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null 2>&1 || \
	    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null; }; }; } || \
	  echo "chromium missing and not root (or not installable): the browser tests are skipped"

test: $(STAMP) $(CORE_STAMP) tools
	$(BIN)/ruff check liftd tests bench
	$(BIN)/ruff format --check liftd tests bench
	$(BIN)/mypy liftd
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	for f in bench/bench_*.py; do $(BIN)/python $$f || exit 1; done

clean:
	test ! -x $(BIN)/python || $(BIN)/python tools/compile_core.py --clean
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache .hypothesis build dist $(NODE_DIR)/node_modules
