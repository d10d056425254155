# rv_copy_files(TARGET name DESTINATION dir FILES f...): a target (built by default) that copies
# the files into dir whenever one of them changes (the Python package's sources, the pages'
# assets), so that the build directory holds what the programs and tests use.
function(rv_copy_files)
  cmake_parse_arguments(C "" "TARGET;DESTINATION" "FILES;DEPENDS" ${ARGN})
  set(copies)
  foreach(src ${C_FILES})
    get_filename_component(name ${src} NAME)
    add_custom_command(OUTPUT ${C_DESTINATION}/${name}
      COMMAND ${CMAKE_COMMAND} -E copy_if_different ${src} ${C_DESTINATION}/${name}
      DEPENDS ${src})
    list(APPEND copies ${C_DESTINATION}/${name})
  endforeach()
  add_custom_target(${C_TARGET} ALL DEPENDS ${copies} ${C_DEPENDS})
endfunction()
