# Builds one layering probe (tests/layering/CMakeLists.txt) and checks the outcome: EXPECT=PASS
# must compile; EXPECT=FAIL must fail because HEADER is not found, not for any other reason.
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BUILD_DIR} --target ${TARGET}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(log "${out}${err}")
if(EXPECT STREQUAL "PASS")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${TARGET}: including ${HEADER} should compile:\n${log}")
  endif()
elseif(rc EQUAL 0)
  message(FATAL_ERROR "${TARGET}: including ${HEADER} compiled, but its target does not link "
                      "the module that owns it")
else()
  string(FIND "${log}" "${HEADER}: No such file" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${TARGET}: failed, but not for the missing ${HEADER}:\n${log}")
  endif()
endif()
message(STATUS "${TARGET}: ${EXPECT} as expected")
