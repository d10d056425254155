#!/usr/bin/env bash
# Fails (exit 1) when a C++ source of the repository differs from what clang-format makes of it
# (.clang-format at the top). Run by CTest (check_format), so a formatting difference fails CI.
# Fix: git ls-files '*.cpp' '*.hpp' '*.h' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
format=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$format" ]; then
  echo "check-format: clang-format not found (tools/setup.sh installs clang-format-14)"
  exit 1
fi
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' 2>/dev/null || find raster vector service tests bench -name '*.[ch]pp')
if ! "$format" --dry-run -Werror "${files[@]}"; then
  echo "check-format: the files above are not formatted; run: git ls-files '*.cpp' '*.hpp' '*.h' | xargs $format -i"
  exit 1
fi
echo "check-format: ${#files[@]} files formatted"
