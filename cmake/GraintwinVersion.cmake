# Stamps the version and git revision into every output's provenance line. The revision is
# looked up at every build, not only at configure time, so an incremental build never stamps
# outputs with an old commit; the generated source is rewritten (and recompiled) only when the
# revision changes.
configure_file(${CMAKE_SOURCE_DIR}/cmake/version.hpp.in
               ${CMAKE_BINARY_DIR}/generated/graintwin/version.hpp @ONLY)
set(GRAINTWIN_GIT_REVISION_SOURCE ${CMAKE_BINARY_DIR}/generated/git_revision.cpp)
add_custom_target(graintwin_git_revision
  COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${CMAKE_SOURCE_DIR} -DOUTPUT=${GRAINTWIN_GIT_REVISION_SOURCE}
          -P ${CMAKE_SOURCE_DIR}/cmake/WriteGitRevision.cmake
  BYPRODUCTS ${GRAINTWIN_GIT_REVISION_SOURCE}
  COMMENT "Looking up the git revision"
  VERBATIM)
