# add_tool(NAME [LIBS lib...]): tools/NAME.cpp -> build/bin/NAME, linked to libcommon.
# The same NAME is the test file (tests/NAME_test.cpp), ctest label, params file and docs page.
set(GRAINTWIN_TOOLS "" CACHE INTERNAL "All tool targets")
function(add_tool name)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  add_executable(${name} ${CMAKE_SOURCE_DIR}/tools/${name}.cpp)
  target_link_libraries(${name} PRIVATE graintwin::common ${ARG_LIBS})
  set(GRAINTWIN_TOOLS ${GRAINTWIN_TOOLS} ${name} CACHE INTERNAL "All tool targets")
endfunction()
