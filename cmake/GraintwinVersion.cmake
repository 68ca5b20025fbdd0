# Stamps the version and git revision into every output's provenance line.
execute_process(COMMAND git describe --always --dirty --abbrev=10
                WORKING_DIRECTORY ${CMAKE_SOURCE_DIR}
                OUTPUT_VARIABLE GRAINTWIN_GIT OUTPUT_STRIP_TRAILING_WHITESPACE
                ERROR_QUIET RESULT_VARIABLE git_rc)
if(NOT git_rc EQUAL 0 OR GRAINTWIN_GIT STREQUAL "")
  set(GRAINTWIN_GIT "unknown")
endif()
configure_file(${CMAKE_SOURCE_DIR}/cmake/version.hpp.in
               ${CMAKE_BINARY_DIR}/generated/graintwin/version.hpp @ONLY)
