# Two commands on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

NODE_DIR := tests/interop/node

.PHONY: run test lint typecheck unit docs bench clean tools core

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,plot,cluster,docs]'
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

# The system tools some tests need (Debian's tshark for the Wireshark interop test, chromium
# for the live view's browser tests, node/npm and the Node ads-client of tests/interop/node) are
# installed by `.ci/run`, never here: `make tools` only says what is missing, and those tests
# skip with the same message (they fail instead under CI=1, where `.ci/run` installed them).
tools:
	@for t in tshark chromium node npm; do command -v $$t >/dev/null || \
	  echo "$$t missing: its tests are skipped (\`.ci/run\` installs it as root)"; done
	@test -d $(NODE_DIR)/node_modules/ads-client || \
	  echo "$(NODE_DIR)/node_modules missing: the Node interop tests are skipped (\`.ci/run\` runs npm ci)"

lint: $(STAMP)
	$(BIN)/ruff check liftd tests bench
	$(BIN)/ruff format --check liftd tests bench

typecheck: $(STAMP)
	$(BIN)/mypy liftd tests/support

unit: $(STAMP) $(CORE_STAMP)
	$(BIN)/python -m pytest -q tests/unit

# the manual (MkDocs): --strict fails on a broken link
docs: $(STAMP)
	$(BIN)/mkdocs build --strict --quiet --site-dir build/site

# the rest two at a time, then the tests that assert wall-clock latencies alone (development.md)
test: lint typecheck docs $(CORE_STAMP) tools
	$(BIN)/python -m pytest -q -n 2 --dist loadfile -m 'not timing'
	$(BIN)/python -m pytest -q -m timing

bench: $(STAMP)
	for f in bench/bench_*.py; do $(BIN)/python $$f || exit 1; done

clean:
	test ! -x $(BIN)/python || $(BIN)/python tools/compile_core.py --clean
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache .hypothesis build dist $(NODE_DIR)/node_modules
