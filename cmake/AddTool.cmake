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
  # CLI11 alone is 3 s of each tool's compile: the first tool precompiles the tools' common
  # headers and every later one reuses them (same flags: all link graintwin::common only publicly).
  if(GRAINTWIN_TOOLS)
    list(GET GRAINTWIN_TOOLS 0 first_tool)
    target_precompile_headers(${name} REUSE_FROM ${first_tool})
  else()
    target_precompile_headers(${name} PRIVATE
      <CLI/CLI.hpp> <spdlog/spdlog.h> <fmt/format.h> <nlohmann/json.hpp>
      <cmath> <filesystem> <fstream> <map> <optional> <string> <vector>)
  endif()
  set(GRAINTWIN_TOOLS ${GRAINTWIN_TOOLS} ${name} CACHE INTERNAL "All tool targets")
endfunction()
