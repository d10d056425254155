# Project-wide compiler settings, applied to every target through rv_target_defaults().
function(rv_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
  if(RV_NATIVE)
    target_compile_options(${target} PRIVATE -march=native)
  endif()
  # float-cast-overflow is not part of GCC's "undefined" group: a double -> integer conversion
  # out of range (cell indexes from coordinates) is exactly the UB this code base could have.
  if(RV_SANITIZE OR RV_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined,float-cast-overflow -fno-omit-frame-pointer
                                             -fno-sanitize-recover=all)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined,float-cast-overflow)
  endif()
  # Fuzz builds: coverage instrumentation for libFuzzer everywhere; the fuzz targets themselves
  # link libFuzzer's main with -fsanitize=fuzzer (tests/fuzz/CMakeLists.txt). A build that also
  # runs the test suite (RV_SANITIZE with RV_FUZZ, CI's one clang build) instruments edges only
  # (8-bit counters and their table, what libFuzzer's coverage feedback reads): the comparison
  # hooks of -fsanitize=fuzzer-no-link would cost a call at every comparison in every test.
  if(RV_FUZZ AND RV_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize-coverage=inline-8bit-counters,pc-table)
  elseif(RV_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
  if(RV_TSAN)
    target_compile_options(${target} PRIVATE -fsanitize=thread -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
endfunction()
