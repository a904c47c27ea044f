# A generated file of the repository is what its script makes now: runs SCRIPT (Python, PYTHON) with
# OUT as its output argument and compares OUT with EXPECTED, byte for byte. Fails naming both files
# and the script to run when they differ (edit the script, not the file).
foreach(var PYTHON SCRIPT OUT EXPECTED)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "regenerate_test.cmake: -D${var}=... is missing")
  endif()
endforeach()
file(REMOVE ${OUT})
get_filename_component(out_dir ${OUT} DIRECTORY)
file(MAKE_DIRECTORY ${out_dir})
execute_process(COMMAND ${PYTHON} ${SCRIPT} ${OUT} RESULT_VARIABLE status OUTPUT_QUIET
  ERROR_VARIABLE errors)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${SCRIPT} failed (${status}):\n${errors}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT} ${EXPECTED} RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "${EXPECTED} is out of date: ${SCRIPT} makes ${OUT}, which differs "
    "(run the script to write it, after editing the script, not the file)")
endif()
