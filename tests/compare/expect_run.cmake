# cmake -DCOMMAND="exe;arg;..." -DEXPECT_EXIT=n [-DEXPECT_REGEX=re] [-DLOG=file] -P expect_run.cmake
# Runs a command and fails unless it exits with EXPECT_EXIT and its output matches EXPECT_REGEX.
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(DEFINED LOG)
  file(WRITE "${LOG}" "${out}${err}")
endif()
if(NOT code STREQUAL "${EXPECT_EXIT}")
  message(FATAL_ERROR "exit code ${code}, expected ${EXPECT_EXIT}")
endif()
if(DEFINED EXPECT_REGEX AND NOT "${out}${err}" MATCHES "${EXPECT_REGEX}")
  message(FATAL_ERROR "output does not match '${EXPECT_REGEX}'")
endif()
