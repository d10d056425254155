# The linker every program, test and module is linked with: RV_LINKER (a name for the compiler's
# -fuse-ld=, default lld; empty: the toolchain's default). About 95 programs link the static
# libraries with debug information, in both of CI's builds; lld links them in a little over half
# GNU ld's time (bench/RESULTS-ci.md). When the compiler cannot link with the linker asked for, its
# default is kept and the configure step says so.
set(RV_LINKER "lld" CACHE STRING "Linker for -fuse-ld= (lld, gold, bfd; empty: the toolchain's default)")
if(RV_LINKER)
  include(CheckLinkerFlag)
  check_linker_flag(CXX "-fuse-ld=${RV_LINKER}" RV_LINKER_WORKS_${RV_LINKER})
  if(RV_LINKER_WORKS_${RV_LINKER})
    add_link_options("-fuse-ld=${RV_LINKER}")
  else()
    message(STATUS "rvoronoi: the compiler cannot link with -fuse-ld=${RV_LINKER}; using its default linker")
  endif()
endif()
