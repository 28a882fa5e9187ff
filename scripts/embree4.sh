#!/usr/bin/env bash
# Provides Embree 4 for `--features embree4` on a machine without an Embree 4
# package (Debian 12 has none), and prints the EMBREE_DIR that build.rs reads:
#
#   export EMBREE_DIR="$(bash scripts/embree4.sh)"
#   cargo test --no-default-features --features embree4
#
# Where it comes from: PyPI's `embreex` wheel (4.4.0) ships Intel's
# libembree4 and the TBB it needs under `embreex.libs/` (auditwheel's renamed
# copies, e.g. libembree4-4aef3270.so.4, which find their TBB through their
# own RPATH of $ORIGIN). It has no headers; the embree4-sys crate carries its
# own. This script unpacks that directory into $EMBREE4_CACHE (default
# ~/.cache/embertrace/embree4-4.4.0) and adds the libembree4.so link the
# linker looks for. Idempotent: a second run only prints the directory.
set -euo pipefail
version=4.4.0
dir="${EMBREE4_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/embertrace/embree4-$version}"
if [ ! -e "$dir/lib/libembree4.so" ]; then
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  . "$(dirname "$0")/unpack-wheel.sh"
  # Any CPython's wheel carries the same library: name one, so that the
  # download does not depend on the Python that runs pip.
  unpack_wheel "embreex==$version" "$tmp/wheel" \
    --python-version 3.11 --platform manylinux_2_28_x86_64
  mkdir -p "$dir/lib"
  cp "$tmp"/wheel/embreex.libs/*.so* "$dir/lib/"
  lib="$(cd "$dir/lib" && ls libembree4-*.so.4 | head -1)"
  [ -n "$lib" ] || { echo "embree4.sh: no libembree4 in the embreex $version wheel" >&2; exit 1; }
  ln -sf "$lib" "$dir/lib/libembree4.so.4"
  ln -sf "$lib" "$dir/lib/libembree4.so"
fi
echo "$dir"
