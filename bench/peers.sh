#!/usr/bin/env bash
# Benchmarks rvoronoi side by side with SciPy, OpenCV, GDAL, GRASS and SAGA on identical inputs
# (bench/peers.py does the work; see its --help). First installs the peers from Debian's archive
# when missing, so that a fresh Debian 12 machine needs nothing else.
#
#   bench/peers.sh [--quick] [--no-install] [--install-only] [peers.py options...]
#
# --quick: small sizes, about a minute; the CI smoke test (CTest label `bench`).
# --no-install: never call apt-get; peers that are missing get a "skipped: not installed" row.
# --install-only: install the peers and stop (CI does this before building).
set -euo pipefail
cd "$(dirname "$0")/.."

install=1
install_only=0
args=()
for a in "$@"; do
  case "$a" in
    --no-install) install=0 ;;
    --install-only) install_only=1 ;;
    *) args+=("$a") ;;
  esac
done

peers=(time python3-numpy python3-scipy python3-opencv gdal-bin python3-gdal grass-core saga python3-geographiclib
       python3-skimage)
if [ "$install" -eq 1 ]; then
  missing=()
  for p in "${peers[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    sudo_cmd=()
    if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
    echo "peers: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    t0=$SECONDS
    "${sudo_cmd[@]}" apt-get update -q
    "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
    # CI's budget depends on this: say how long it took.
    echo "peers: installed in $((SECONDS - t0)) s" >&2
  fi
fi
if [ "$install_only" -eq 1 ]; then exit 0; fi

# Debian's Python: the peers' modules are installed for it, not for any other python3 on PATH.
exec /usr/bin/python3 bench/peers.py ${args[@]+"${args[@]}"}
