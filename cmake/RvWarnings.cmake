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
  # link libFuzzer's main with -fsanitize=fuzzer (tests/fuzz/CMakeLists.txt).
  if(RV_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
  if(RV_TSAN)
    target_compile_options(${target} PRIVATE -fsanitize=thread -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
endfunction()
