# The image the Kubernetes manifests (deploy/k8s/) run: the embertrace binary
# on Debian 12 with Debian's Embree 3. Not built in this repository's CI (its
# machine has no container runtime); build it where one is:
#
#   docker build -t registry.example.com/embertrace:0.2.0 .
#   docker run --rm -v "$PWD/scenes:/scenes" registry.example.com/embertrace:0.2.0 \
#       render /scenes/cornell-box.toml -o /scenes/out.png
#
# The build stage needs Embree's headers and libclang (bindgen); the runtime
# stage only Embree's shared library.

FROM rust:1-bookworm AS build
RUN apt-get update \
    && apt-get install -y --no-install-recommends libembree-dev libclang-dev \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY . .
RUN cargo build --release --locked \
    && install -m 0755 target/release/embertrace /usr/local/bin/embertrace

FROM debian:bookworm-slim
RUN apt-get update \
    && apt-get install -y --no-install-recommends libembree3-3 \
    && rm -rf /var/lib/apt/lists/*
COPY --from=build /usr/local/bin/embertrace /usr/local/bin/embertrace
ENTRYPOINT ["embertrace"]
