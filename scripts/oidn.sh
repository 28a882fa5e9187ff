#!/usr/bin/env bash
# Provides Intel Open Image Denoise for `--features denoise` on a machine
# without an OIDN package (Debian 12 has none), and prints the OIDN_DIR that
# the oidn crate's build and build.rs read:
#
#   export OIDN_DIR="$(bash scripts/oidn.sh)"
#   cargo build --release --features denoise
#
# Where it comes from: PyPI's `pyoidn` wheel (2.5.1.0) ships Intel's
# OpenImageDenoise 2.5.1 build under `pyoidn/oidn/lib/`: the API library
# (libOpenImageDenoise.so.2), the core with the trained weights, one module per
# device, and TBB. This script keeps the CPU device (the GPU modules and the
# SYCL runtime are 25 MB of what this renderer does not use; OIDN skips
# modules it does not find) in $OIDN_CACHE (default
# ~/.cache/embertrace/oidn-2.5.1). Idempotent: a second run only prints the
# directory. Other ways to get OIDN: Intel's release archives
# (github.com/RenderKit/oidn/releases, set OIDN_DIR to the unpacked folder)
# or a distribution's package (found through pkg-config).
set -euo pipefail
version=2.5.1
dir="${OIDN_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/embertrace/oidn-$version}"
if [ ! -e "$dir/lib/libOpenImageDenoise.so" ]; then
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  . "$(dirname "$0")/unpack-wheel.sh"
  unpack_wheel "pyoidn==$version.0" "$tmp/wheel" --platform manylinux2014_x86_64
  lib="$tmp/wheel/pyoidn/oidn/lib"
  mkdir -p "$dir/lib.partial"
  for f in "$lib"/libOpenImageDenoise.so* "$lib"/libOpenImageDenoise_core.so* \
           "$lib"/libOpenImageDenoise_device_cpu.so* "$lib"/libtbb.so*; do
    cp -P "$f" "$dir/lib.partial/"
  done
  rm -rf "$dir/lib"
  mv "$dir/lib.partial" "$dir/lib"
fi
echo "$dir"
