#!/usr/bin/env bash
# The Python package as a user installs it (issue 49), run by CTest (test_python_package):
#   1. `pip install --no-build-isolation .` into a fresh venv made with --system-site-packages
#      (Debian's Python refuses installs into the system: PEP 668), offline (--no-index),
#      reusing the build tree given (RV_CMAKE_BUILD_DIR) instead of building a second time;
#   2. `pip wheel` makes rvoronoi-<version>-cp3XX-cp3XX-linux_x86_64.whl;
#   3. the Python tests against the installed package, from a folder outside the checkout with no
#      PYTHONPATH, so that they cannot import the build tree's copy;
#   4. a missing build dependency (no cmake on PATH) stops `pip install` with the line naming the
#      Debian package to install, and leaves nothing installed.
# usage: tools/test-python-package.sh BUILD_DIR
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
work=$(mktemp -d /tmp/rvoronoi-package-test.XXXXXX)
trap 'rm -rf "$work"' EXIT
unset PYTHONPATH
version=$("$build/service/rvoronoi" --version | awk '{print $NF}')
stamp() { date +%s.%N; }
took() { awk -v a="$1" -v b="$(stamp)" 'BEGIN { printf "%.1f s", b - a }'; }

t=$(stamp)
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
(cd "$root" && RV_CMAKE_BUILD_DIR=$build "$work/venv/bin/pip" install -q --no-index --no-build-isolation .)
echo "package: installed into a fresh venv in $(took "$t")"
installed=$(cd "$work" && "$work/venv/bin/python" -c 'import rvoronoi; print(rvoronoi.__file__)')
case "$installed" in
  "$work/venv/"*) echo "package: imported from $installed" ;;
  *) echo "package: FAILED: rvoronoi imported from $installed, not the venv"; exit 1 ;;
esac

t=$(stamp)
(cd "$root" && RV_CMAKE_BUILD_DIR=$build "$work/venv/bin/pip" wheel -q --no-index --no-build-isolation --no-deps \
  -w "$work/wheels" .)
wheel=$(ls "$work/wheels")
case "$wheel" in
  "rvoronoi-$version-cp3"*"-linux_x86_64.whl") echo "package: wheel $wheel in $(took "$t")" ;;
  *) echo "package: FAILED: unexpected wheel '$wheel' (version $version)"; exit 1 ;;
esac
for member in rvoronoi/__init__.py rvoronoi/__init__.pyi rvoronoi/py.typed rvoronoi/_rvoronoi.cpython-3; do
  /usr/bin/python3 -c 'import sys, zipfile; names = zipfile.ZipFile(sys.argv[1]).namelist()
sys.exit(0 if any(n.startswith(sys.argv[2]) for n in names) else 1)' "$work/wheels/$wheel" "$member" ||
    { echo "package: FAILED: the wheel lacks $member"; exit 1; }
done

t=$(stamp)
cd "$work"
"$work/venv/bin/python" "$root/tests/python/test_module.py" "$build/service/rvoronoi" "$root"
"$work/venv/bin/python" "$root/tests/python/test_dask.py" "$root"
echo "package: the Python tests passed against the installed package in $(took "$t")"

# No cmake on PATH: one line naming the package, and nothing installed in a second fresh venv.
/usr/bin/python3 -m venv --system-site-packages "$work/venv2"
set +e
out=$(cd "$root" && PATH="$work/venv2/bin" "$work/venv2/bin/pip" install --no-index --no-build-isolation . 2>&1)
status=$?
set -e
if [ "$status" -eq 0 ] || ! grep -q "rvoronoi: CMake is missing: install the Debian package cmake" <<<"$out"; then
  echo "package: FAILED: a missing cmake was not named (exit $status):"
  echo "$out" | tail -20
  exit 1
fi
if (cd "$work" && "$work/venv2/bin/python" -c 'import rvoronoi' 2>/dev/null); then
  echo "package: FAILED: a failed install left rvoronoi importable"
  exit 1
fi
echo "package: a missing cmake stops pip install with: $(grep -o 'rvoronoi: CMake is missing[^)]*)' <<<"$out" | head -1)"
echo "package: 4 passed, 0 failed"
