#!/usr/bin/env bash
# Builds the Debian package dist/rvoronoi_<version>_<arch>.deb (CPack, packaging/CMakeLists.txt):
# the rvoronoi command, the daemon's systemd unit and configuration, the Python module, the pages'
# assets and the man page. Reuses the build tree (./build, or RV_BUILD_DIR) and builds in it only
# what the package holds; configures it first when there is none. Needs what tools/setup.sh
# installs. Prints the package's path last. tools/test-package.sh tests the package.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${RV_BUILD_DIR:-build}

# CPack's DEB generator finds the ELF files with `file` and their libraries with dpkg-shlibdeps.
for tool in file:file dpkg-shlibdeps:dpkg-dev; do
  if ! command -v "${tool%%:*}" >/dev/null 2>&1; then
    echo "package: ${tool%%:*} is missing: apt-get install ${tool#*:}" >&2
    exit 1
  fi
done
if [ -n "$(git status --porcelain 2>/dev/null)" ]; then
  echo "package: the git tree has uncommitted changes; packaging them all the same"
fi
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
# The package's files only (the programs, the Python package, the pages, the man page): not the tests.
cmake --build "$build_dir" -j "$(nproc)" --target rvoronoi_package_files

mkdir -p dist
rm -f dist/rvoronoi_*.deb
cpack --config "$build_dir/CPackConfig.cmake" -B "$PWD/dist" >/dev/null
rm -rf dist/_CPack_Packages
debs=(dist/rvoronoi_*.deb)
echo "package: ${debs[0]}"
