# add_tool(NAME [LIBS lib...]): tools/NAME.cpp -> build/bin/NAME, linked to libcommon.
# The same NAME is the test file (tests/NAME_test.cpp), ctest label, params file and docs page.
set(GRAINTWIN_TOOLS "" CACHE INTERNAL "All tool targets")
function(add_tool name)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  add_executable(${name} ${CMAKE_SOURCE_DIR}/tools/${name}.cpp)
  target_link_libraries(${name} PRIVATE graintwin::common ${ARG_LIBS})
  # A tool's own code is its options and one library call: -O1 compiles CLI11's templates in two
  # thirds of -O3's time, and the work runs in the library, built at -O3.
  target_compile_options(${name} PRIVATE $<$<CONFIG:Release>:-O1>)
  set(GRAINTWIN_TOOLS ${GRAINTWIN_TOOLS} ${name} CACHE INTERNAL "All tool targets")
endfunction()
