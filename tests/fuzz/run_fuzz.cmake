# cmake -DFUZZER=exe -DCORPUS=dir -DARTIFACTS=dir -DARGS=list -P run_fuzz.cmake
# Runs the libFuzzer binary (fuzz.loader) from an empty corpus folder, as on a clean clone, so
# that a run here with the same seed is CI's run. When it fails, the log ends with what a
# truncated CI log would otherwise lose: the sanitizer's or the target's report and the failing
# input itself (text, at most 16 kB), to be kept in tests/fuzz/regressions/ from the log.
file(REMOVE_RECURSE "${CORPUS}" "${ARTIFACTS}")
file(MAKE_DIRECTORY "${CORPUS}" "${ARTIFACTS}")
execute_process(COMMAND "${FUZZER}" ${ARGS} RESULT_VARIABLE code OUTPUT_VARIABLE out
                ERROR_VARIABLE out)
if(code EQUAL 0)
  string(REGEX MATCHALL "(stat::[^\n]*|#[0-9]+[ \t]+DONE[^\n]*)" stats "${out}")
  string(JOIN "\n" stats ${stats})
  message("${stats}")
  return()
endif()
message("${out}")
# The report's first lines: the sanitizer's error or the target's violation and the frames under
# it (CMake's regular expressions have no counted repeats: a slice of the text instead).
set(report "")
foreach(marker "==ERROR" "runtime error" "fuzz_loader: " "ERROR: libFuzzer")
  string(FIND "${out}" "${marker}" at)
  if(at GREATER_EQUAL 0)
    string(SUBSTRING "${out}" ${at} 2500 report)
    break()
  endif()
endforeach()
file(GLOB inputs "${ARTIFACTS}/crash-*" "${ARTIFACTS}/timeout-*" "${ARTIFACTS}/oom-*"
     "${ARTIFACTS}/leak-*")
message("---- report ----\n${report}")
foreach(input IN LISTS inputs)
  file(READ "${input}" text)
  message("---- failing input ${input} ----\n${text}\n---- end of input ----")
endforeach()
message(FATAL_ERROR "fuzz_loader failed (exit ${code}); the failing input is above")
