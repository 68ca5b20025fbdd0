# Writes docs/tools/<tool>.md from `<tool> --help`; run through the `docs` target.
string(REPLACE "," ";" TOOLS "${TOOLS}")
foreach(tool IN LISTS TOOLS)
  execute_process(COMMAND ${BIN_DIR}/${tool} --help OUTPUT_VARIABLE help RESULT_VARIABLE rc
)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${tool} --help exited ${rc}")
  endif()
  file(WRITE ${DOCS_DIR}/${tool}.md
       "# ${tool}\n\n<!-- generated from `${tool} --help` by `cmake --build build -t docs`; do not edit -->\n\n```text\n${help}```\n")
endforeach()
