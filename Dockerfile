# liftd in a container. Build: docker build -t liftd .
# Run (README "Docker"):
#   docker run --rm --init -p 127.0.0.1:48898:48898 \
#     --ulimit rtprio=80 --ulimit memlock=-1 --cap-drop=ALL --security-opt no-new-privileges \
#     --read-only --tmpfs /tmp -v "$PWD/myconfig:/etc/liftd:ro" liftd
# The host kernel decides real-time latency; the flags above only let the GEO loop ask for
# SCHED_FIFO and mlockall as the non-root user (reference/rt-python.md §7).

FROM python:3.11-slim-bookworm AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
COPY pyproject.toml README.md ./
COPY liftd ./liftd
COPY config ./config
RUN python -m venv /opt/liftd \
 && /opt/liftd/bin/pip install --upgrade pip \
 && /opt/liftd/bin/pip install .

FROM python:3.11-slim-bookworm
ENV PATH=/opt/liftd/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    OPENBLAS_NUM_THREADS=1 \
    LIFTD_CONFIG=/etc/liftd/liftd.toml
COPY --from=build /opt/liftd /opt/liftd
# The shipped lists and demo, with a configuration that listens on the container's addresses
# and accepts private peer ranges (docker/liftd.toml).
COPY config /etc/liftd
COPY docker/liftd.toml /etc/liftd/liftd.toml
RUN useradd --system --uid 10001 --no-create-home --shell /usr/sbin/nologin liftd \
 && mkdir -p /var/lib/liftd && chown liftd:liftd /var/lib/liftd
USER 10001
VOLUME ["/etc/liftd"]
WORKDIR /var/lib/liftd
EXPOSE 48898
STOPSIGNAL SIGTERM
HEALTHCHECK --interval=10s --timeout=5s --start-period=5s --retries=3 \
  CMD ["liftd", "healthcheck"]
ENTRYPOINT ["liftd"]
CMD ["run"]
