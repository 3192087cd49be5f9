# liftd in a container. Build: docker build -t liftd .
# A worker for `liftd study --scheduler` (README "A study on a Dask cluster"):
#   docker build --build-arg EXTRAS=cluster -t liftd-worker .
#   docker run --rm --network host --entrypoint dask liftd-worker worker tcp://SCHEDULER:8786 --nthreads 1
# Run (README "Docker"):
#   docker run --rm --init -p 127.0.0.1:48898:48898 -p 127.0.0.1:8551:8551 \
#     --ulimit rtprio=80 --ulimit memlock=-1 --cap-drop=ALL --security-opt no-new-privileges \
#     --read-only --tmpfs /tmp -v "$PWD/myconfig:/etc/liftd:ro" liftd
# The host kernel decides real-time latency; the flags above only let the GEO loop ask for
# SCHED_FIFO and mlockall as the non-root user (see README "Running it as a service").
#
# Reproducible: every Python package (and the build backend) is pinned in
# docker/constraints.txt; pip is the base image's own, not upgraded. Pin the base image by
# digest too: --build-arg PYTHON_IMAGE=python:3.11-slim-bookworm@sha256:…  Two --no-cache
# builds of one tree then hold the same files, the compiled core included, except the .pyc
# caches the build's own Python runs write (they embed build-time mtimes); not bit-identical.
ARG PYTHON_IMAGE=python:3.11-slim-bookworm

FROM ${PYTHON_IMAGE} AS build
# optional extras of liftd, e.g. cluster (distributed, for a Dask worker); none by default
ARG EXTRAS=
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PIP_CONSTRAINT=/src/docker/constraints.txt
# A C compiler for the compiled GEO core (mypyc, tools/compile_core.py), in this stage only
RUN apt-get update \
 && apt-get install -y --no-install-recommends gcc libc6-dev \
 && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY pyproject.toml README.md ./
COPY docker/constraints.txt ./docker/constraints.txt
COPY liftd ./liftd
COPY config ./config
COPY tools ./tools
# install (mypyc type-checks against the dependencies), compile in place, install again with
# the extensions (pyproject: wheel artifacts), then drop mypy: the extensions do not need it.
# `liftd --version` must say "GEO core: compiled", or the build fails.
RUN python -m venv /opt/liftd \
 && /opt/liftd/bin/pip install --no-compile ".${EXTRAS:+[$EXTRAS]}" mypy \
 && /opt/liftd/bin/python tools/compile_core.py \
 && /opt/liftd/bin/pip install --no-compile --no-deps --force-reinstall . \
 && /opt/liftd/bin/pip uninstall -y mypy mypy-extensions librt ast-serialize pathspec \
 && cd / && /opt/liftd/bin/liftd --version | grep -q "GEO core: compiled"

FROM ${PYTHON_IMAGE}
ARG VERSION=0.1.0
LABEL org.opencontainers.image.title="liftd" \
      org.opencontainers.image.description="Emulated TwinCAT 3 CNC GEO task (collision avoidance by lifting), served over ADS" \
      org.opencontainers.image.version="${VERSION}" \
      org.opencontainers.image.licenses="Apache-2.0" \
      org.opencontainers.image.documentation="/usr/share/doc/liftd/README.md"
ENV PATH=/opt/liftd/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    OPENBLAS_NUM_THREADS=1 \
    LIFTD_CONFIG=/etc/liftd/liftd.toml \
    LIFTD_HEARTBEAT=/tmp/liftd.heartbeat
COPY --from=build /opt/liftd /opt/liftd
COPY README.md /usr/share/doc/liftd/README.md
COPY docs/architecture.md /usr/share/doc/liftd/architecture.md
# The shipped lists and demo, with a configuration that listens on the container's addresses
# and accepts private peer ranges (docker/liftd.toml). No VOLUME: mount your own /etc/liftd
# (read-only) to replace it; an anonymous volume would hide the shipped one on every run.
COPY config /etc/liftd
COPY docker/liftd.toml /etc/liftd/liftd.toml
RUN useradd --system --uid 10001 --no-create-home --shell /usr/sbin/nologin liftd \
 && mkdir -p /var/lib/liftd && chown liftd:liftd /var/lib/liftd
USER 10001
WORKDIR /var/lib/liftd
EXPOSE 48898 8551
STOPSIGNAL SIGTERM
# The daemon renews $LIFTD_HEARTBEAT every second while its GEO loop cycles (the condition of
# systemd's WATCHDOG=1); healthy = renewed within 5 s. No Python start-up every 10 s;
# `liftd healthcheck` probes over ADS from anywhere else.
HEALTHCHECK --interval=10s --timeout=3s --start-period=10s --retries=3 \
  CMD ["/bin/sh", "-c", "t=$(stat -c %Y \"$LIFTD_HEARTBEAT\") && test $(( $(date +%s) - t )) -le 5"]
ENTRYPOINT ["liftd"]
CMD ["run"]
