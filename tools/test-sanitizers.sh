#!/usr/bin/env bash
# The sanitizer stages of CI (run by .ci/run after tools/test.sh), from one clang build in
# build-asan/ (ASan + UBSan, -DRV_SANITIZE=ON, with the libFuzzer targets, -DRV_FUZZ=ON):
#   1. the whole test suite; any report fails its test (options in tests/CMakeLists.txt).
#      Clang, not GCC: it compiles this code under the sanitizers in less than half the time
#      (server.cpp 55 s against 112 s, test_edit_job.cpp 33 s against 70 s, boundaries.cpp 16 s
#      against 37 s, one after the other on the project's 2-core VM), and it evaluates arguments
#      left to right where GCC goes right to left, so the main build (GCC) and this stage see both
#      orders (clang's ASan found a use-after-free that GCC's order hid);
#   2. the libFuzzer targets of tests/fuzz, each run for RV_FUZZ_SECONDS (default 15: twelve
#      targets, three minutes of fuzzing, kept so since CI neared its hour; as many at once as
#      there are cores) from its
#      seed corpus in tests/fuzz/corpus/<target>/. A crash, sanitizer report, leak or timeout
#      fails CI; the input is kept under build-asan/fuzz-artifacts/ to reproduce with
#      `build-asan/tests/fuzz/<target> <file>`.
# One build, not one per stage: the libraries were compiled twice under the same sanitizers,
# and the second build was the part of CI's hour that the budget could not keep. In this build
# the libraries carry edge coverage only (cmake/RvWarnings.cmake), which is what libFuzzer's
# feedback reads; a fuzz-only build (-DRV_FUZZ=ON alone) adds the comparison hooks.
# RV_SANITIZER_STAGES picks stages (default "asan fuzz"); tools/test-tsan.sh is the TSan stage.
# Prints the wall time of each stage.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh --sanitizers
jobs=$(nproc)
stages=${RV_SANITIZER_STAGES:-asan fuzz}
fuzz_seconds=${RV_FUZZ_SECONDS:-15}
root=$PWD

stamp() { date +%s; }

# The build both stages read: the tests only when the suite runs, the fuzz targets only when
# they do. The benchmarks are left out (the stage runs none). Debug information is line tables
# only (-g1): a report's stack still names every function, file and line, and the build is about
# a fifth shorter (server.cpp under ASan: 119 s against 153 s with -g).
t0=$(stamp)
tests=OFF
fuzz=OFF
if [[ " $stages " == *" asan "* ]]; then tests=ON; fi
if [[ " $stages " == *" fuzz "* ]]; then fuzz=ON; fi
CC=clang-14 CXX=clang++-14 cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRV_SANITIZE=ON \
  -DRV_FUZZ="$fuzz" -DRV_BUILD_TESTS="$tests" -DRV_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" >/dev/null
cmake --build build-asan -j "$jobs"
t1=$(stamp)
echo "sanitizers: clang asan+ubsan build (tests $tests, fuzz targets $fuzz) $((t1 - t0)) s"

if [[ " $stages " == *" asan "* ]]; then
  t1=$(stamp)
  # The bench smoke test (label bench) runs third-party tools; it adds time, not sanitizer coverage.
  ctest --test-dir build-asan --output-on-failure --timeout 900 -j "$jobs" -LE bench
  t2=$(stamp)
  echo "sanitizers: asan+ubsan tests $((t2 - t1)) s"
fi

if [[ " $stages " == *" fuzz "* ]]; then
  targets=$(cat build-asan/fuzz_targets.txt)  # the targets tests/fuzz/CMakeLists.txt defines
  export LSAN_OPTIONS="suppressions=$root/tools/lsan.supp:print_suppressions=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  export ASAN_OPTIONS="abort_on_error=1:detect_leaks=1"
  # One fuzzer is one process on one core: the targets run $jobs at a time, each for its own
  # RV_FUZZ_SECONDS, so every target gets the same time as one after the other, in 1/$jobs of it.
  fuzz_one() {
    local t=$1 s
    local work="build-asan/fuzz-corpus/$t"
    mkdir -p "$work" build-asan/fuzz-artifacts
    s=$(stamp)
    if ! "build-asan/tests/fuzz/$t" -max_total_time="$fuzz_seconds" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="build-asan/fuzz-artifacts/$t-" "$work" "tests/fuzz/corpus/$t" 2>"build-asan/fuzz-$t.log"; then
      tail -n 60 "build-asan/fuzz-$t.log"
      echo "sanitizers: fuzz target $t FAILED (log: build-asan/fuzz-$t.log)"
      return 1
    fi
    local runs
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "build-asan/fuzz-$t.log" | grep -o '[0-9]*$' || echo "?")
    echo "sanitizers: fuzz $t $(($(stamp) - s)) s, $runs runs, no findings"
  }
  t3=$(stamp)
  failed=0
  running=0
  for t in $targets; do
    if ((running >= jobs)); then
      wait -n || failed=1
      running=$((running - 1))
    fi
    fuzz_one "$t" &
    running=$((running + 1))
  done
  while ((running > 0)); do
    wait -n || failed=1
    running=$((running - 1))
  done
  echo "sanitizers: fuzzing $(($(stamp) - t3)) s"
  if ((failed)); then
    echo "sanitizers: fuzzing found something (above)"
    exit 1
  fi
fi
