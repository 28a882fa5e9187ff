# Sourced by scripts/embree4.sh and scripts/oidn.sh: unpack_wheel SPEC DEST
# [PIP ARGS...] downloads the binary wheel SPEC (e.g. embreex==4.4.0) from
# PyPI with pip, without its dependencies, and unpacks it into DEST. A
# machine whose Python has no pip (a bare Debian 12) gets python3-pip first.
unpack_wheel() {
  local spec="$1" dest="$2"
  shift 2
  if ! python3 -m pip --version >/dev/null 2>&1; then
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "installing python3-pip (apt-get), to download $spec" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq python3-pip >/dev/null
  fi
  local download
  download="$(mktemp -d)"
  python3 -m pip download -q --no-deps --only-binary=:all: "$@" "$spec" -d "$download" >&2
  python3 -m zipfile -e "$download"/*.whl "$dest"
  rm -rf "$download"
}
