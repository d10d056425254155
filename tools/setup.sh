#!/usr/bin/env bash
# Installs the Debian 12 packages rvoronoi needs to build, test and run, and the map page's npm
# packages (web/). Idempotent: what is already present is not installed again, so a second run
# takes a second.
# --image: the daemon image's set (docker/Dockerfile), without the Python and browser test tools.
# --sanitizers adds the toolchain of tools/test-sanitizers.sh: clang and its runtimes (libFuzzer,
# ASan/UBSan for clang). GCC's ASan/UBSan/TSan runtimes come with build-essential. The daemon
# image (docker/Dockerfile) does not pass it.
set -euo pipefail

packages=(
  # lld: the linker the build asks for (cmake/RvLinker.cmake)
  build-essential cmake ninja-build pkg-config lld
  libgdal-dev gdal-bin python3-gdal libproj-dev
  libtiff-dev libzstd-dev libdeflate-dev
  libgeographiclib-dev
  libgtest-dev libgmock-dev
  pybind11-dev python3-dev python3-pip python3-venv python3-setuptools python3-wheel
  libboost-dev libsqlite3-dev nlohmann-json3-dev libssl-dev ca-certificates
  libpq-dev
  libopencv-dev
  python3-jsonschema python3-yaml python3-numpy
  clang-format-14
  curl
  file
)

# What the Python package imports and the tests drive (xarray, Dask, GeoPandas; headless
# Chromium for the pages): not in the daemon image (--image), which builds the module but runs
# neither.
if [ "${1:-}" != "--image" ]; then
  packages+=(python3-xarray python3-dask python3-distributed python3-geopandas python3-rioxarray python3-zarr
             python3-netcdf4 python3-psutil chromium chromium-driver python3-selenium)
  # The principals' test signs JWTs and serves a key set over TLS with keys it makes.
  packages+=(python3-jwt python3-cryptography)
  # The QGIS provider's test: Debian's QGIS 3.22, headless (qgis_process.bin, PyQGIS).
  packages+=(qgis python3-qgis)
  # The Debian package's test (tools/test-package.sh): a minimal chroot, lintian, the unit's checks,
  # a network namespace for the installed daemon.
  packages+=(debootstrap lintian systemd iproute2 zstd)
  # The shared service's tests (issue 55) start a PostgreSQL 15 server of their own (initdb in a
  # temporary folder, as the postgres user) and an S3 server from npm (tests/package.json).
  packages+=(postgresql-15)
fi
if [ "${1:-}" = "--sanitizers" ]; then
  packages+=(clang-14 libclang-rt-14-dev)
fi
# The map page's libraries (web/package.json) come from the npm registry through npm: the
# machine's Node.js and npm when it has them, else Debian's.
if ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# web/node_modules exactly as web/package-lock.json pins it, installed again only when the lock
# file changed (a stamp keeps the lock file it was installed from). No package's install script
# runs: esbuild's only checks that its platform binary, an optional dependency, is there.
web="$(cd "$(dirname "$0")/.." && pwd)/web"
if ! cmp -s "$web/package-lock.json" "$web/node_modules/.rvoronoi-lock" 2>/dev/null; then
  echo "setup: installing the map page's libraries (npm ci in web/)"
  npm ci --prefix "$web" --ignore-scripts --no-audit --no-fund --loglevel=error
  cp "$web/package-lock.json" "$web/node_modules/.rvoronoi-lock"
fi

# The S3 server the shared service's tests start (tests/service/shared/package.json: s3rver), the
# same way; not in the daemon image.
if [ "${1:-}" != "--image" ]; then
  shared="$(cd "$(dirname "$0")/.." && pwd)/tests/service/shared"
  if ! cmp -s "$shared/package-lock.json" "$shared/node_modules/.rvoronoi-lock" 2>/dev/null; then
    echo "setup: installing the tests' S3 server (npm ci in tests/service/shared/)"
    npm ci --prefix "$shared" --ignore-scripts --no-audit --no-fund --loglevel=error
    cp "$shared/package-lock.json" "$shared/node_modules/.rvoronoi-lock"
  fi
fi
