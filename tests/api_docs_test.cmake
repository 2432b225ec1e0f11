# ctest driver for ApiReferenceDocumented: runs Doxygen over the public headers (DOXYFILE, configured from
# docs/Doxyfile.in with every warning an error) and fails listing each warning, e.g. a public member without a ///
# comment or a comment naming a parameter that does not exist.
get_filename_component(folder "${WARNINGS}" DIRECTORY)
file(MAKE_DIRECTORY "${folder}")
file(REMOVE "${WARNINGS}")
execute_process(COMMAND ${DOXYGEN} ${DOXYFILE} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(warnings "")
if(EXISTS "${WARNINGS}")
  file(READ "${WARNINGS}" warnings)
endif()
string(REGEX MATCHALL "[^\n]+" lines "${warnings}")
list(LENGTH lines count)
if(NOT rc EQUAL 0 OR count GREATER 0)
  message(FATAL_ERROR "doxygen: ${count} warnings over the public headers (exit ${rc}):\n${warnings}\n${out}\n${err}")
endif()
message(STATUS "doxygen: every public member of the installed headers is documented")
