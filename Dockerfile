# hgraph-server image: built on Debian 12 with the project's own scripts, run on bookworm-slim
# with only the runtime libraries (scripts/runtime-packages.txt, checked against the binaries by
# the ctest docker.runtime_libs), as a non-root user.
#   docker build -t hgraph-server:0.1.0 .
#   docker run --rm -p 50051:50051 -p 9464:9464 hgraph-server:0.1.0
#   docker run --rm --entrypoint hgraph hgraph-server:0.1.0 health --server HOST:50052

FROM debian:bookworm AS build
WORKDIR /src
# The dependencies first, so that a source change reuses this layer.
COPY scripts/install-deps.sh scripts/
RUN bash scripts/install-deps.sh --build && rm -rf /var/lib/apt/lists/*
COPY . .
# The shipped binaries only; hgraph-mesh-import (the sandboxed mesh parser the server starts
# beside itself) when this tree has it.
RUN targets="hgraph-server hgraph"; \
    if grep -rqs --include=CMakeLists.txt "add_executable(hgraph-mesh-import" .; then \
      targets="$targets hgraph-mesh-import"; \
    fi; \
    HGRAPH_JOBS="$(nproc)" HGRAPH_TARGETS="$targets" bash scripts/build.sh /src/build && \
    mkdir -p /out/bin && \
    for t in $targets; do cp "$(find build -type f -name "$t" -perm -u+x | head -n 1)" /out/bin/; done && \
    strip --strip-debug /out/bin/*

FROM debian:bookworm-slim AS runtime
COPY scripts/runtime-packages.txt /tmp/runtime-packages.txt
RUN apt-get update -q && \
    grep -v '^#' /tmp/runtime-packages.txt | xargs apt-get install -y -q --no-install-recommends && \
    rm -rf /var/lib/apt/lists/* /tmp/runtime-packages.txt && \
    groupadd --system --gid 10001 hgraph && \
    useradd --system --uid 10001 --gid hgraph --home-dir /nonexistent --shell /usr/sbin/nologin hgraph
# hgraph-server, the hgraph CLI and (if built) hgraph-mesh-import side by side.
COPY --from=build /out/bin/ /usr/local/bin/
# The built-in scenes, for `hgraph plan|merge --scene /usr/share/hgraph/scenes/<name>/scene.json`.
COPY scenes/ /usr/share/hgraph/scenes/
USER 10001:10001
# The health-only port (--health-listen, plaintext, grpc.health.v1 only) is on whatever
# arguments the container gets: from the environment, so that the HEALTHCHECK works when the
# gRPC port speaks TLS (--tls-cert), as Kubernetes' probes of deploy/ do. `--health-listen ""`
# (or `docker run -e HGRAPH_HEALTH_LISTEN=`) turns it off; the HEALTHCHECK then fails.
ENV HGRAPH_HEALTH_LISTEN=0.0.0.0:50052
EXPOSE 50051 9464 50052
HEALTHCHECK --interval=10s --timeout=5s --start-period=5s --retries=3 \
  CMD ["hgraph", "health", "--server", "127.0.0.1:50052"]
ENTRYPOINT ["hgraph-server"]
CMD ["--listen=0.0.0.0:50051", "--metrics-listen=0.0.0.0:9464"]
