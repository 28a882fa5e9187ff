#!/usr/bin/env bash
# Installs the Debian packages embertrace needs, if any is missing:
# Embree 3 (libembree-dev) and libclang (for bindgen). Idempotent and quiet
# when everything is present. Sourced by scripts/run, scripts/test and .ci/run.
# With --denoise it also provides Intel Open Image Denoise for
# `--features denoise` (scripts/oidn.sh) and prints its OIDN_DIR:
#   export OIDN_DIR="$(bash scripts/deps.sh --denoise)"
set -euo pipefail
need=()
[ -f /usr/include/embree3/rtcore.h ] || need+=(libembree-dev)
# (libclang-cpp.so, which other packages bring, is not the C library bindgen loads)
ls /usr/lib/llvm-*/lib/libclang.so* >/dev/null 2>&1 || ls /usr/lib/x86_64-linux-gnu/libclang.so* /usr/lib/x86_64-linux-gnu/libclang-[0-9]*.so* >/dev/null 2>&1 || need+=(libclang-dev)
if [ "${#need[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing ${need[*]} (apt-get)" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi
if [ "${1:-}" = "--denoise" ]; then
  bash "$(dirname "$0")/oidn.sh"
fi
