# ctest fixture: runs CPack into a directory of its own (cmake -P; CPACK, CONFIG, OUT).
file(REMOVE_RECURSE ${OUT})
execute_process(COMMAND ${CPACK} --config ${CONFIG} -B ${OUT} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cpack failed (${rc}); build every target first (cmake --build --preset <preset>)")
endif()
