# cmake -DCROSSLINK=exe -DDOC=docs/first-definition.md -DOUT=dir -P tutorial_test.cmake
# Walks docs/first-definition.md: takes the file under its "tutorial-file" marker, runs the
# page's commands (check, solve, compare with a report) and asserts the numbers the page shows,
# which are the closed forms it derives (law of cosines), not crosslink's output copied.
file(READ "${DOC}" doc)
string(FIND "${doc}" "<!-- tutorial-file -->" at)
if(at LESS 0)
  message(FATAL_ERROR "${DOC} has no tutorial-file marker")
endif()
string(SUBSTRING "${doc}" ${at} -1 rest)
string(FIND "${rest}" "```toml\n" open)
math(EXPR open "${open} + 8")
string(SUBSTRING "${rest}" ${open} -1 rest)
string(FIND "${rest}" "```" close)
string(SUBSTRING "${rest}" 0 ${close} toml)
file(MAKE_DIRECTORY "${OUT}")
set(file "${OUT}/crank_rocker.toml")
file(WRITE "${file}" "${toml}")

function(expect_run expected_exit)
  execute_process(COMMAND "${CROSSLINK}" ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  message("$ crosslink ${ARGN}\n${out}${err}")
  if(NOT code STREQUAL "${expected_exit}")
    message(FATAL_ERROR "exit ${code}, expected ${expected_exit}")
  endif()
  set(run_output "${out}${err}" PARENT_SCOPE)
endfunction()

function(expect_match text)
  foreach(re IN LISTS ARGN)
    if(NOT text MATCHES "${re}")
      message(FATAL_ERROR "no match for '${re}'")
    endif()
  endforeach()
endfunction()

# 3. check: mobility 1, full rotation, a Grashof crank-rocker, mu from 45.5730 to 132.1774 deg
#    (cos mu = 0.7 and -4700/7000).
expect_run(0 check "${file}")
expect_match("${run_output}" "M = 3\\(n-1\\) - 2 j1 - j2 = 3\\(4-1\\) - 2\\*4 - 0 = 1"
             "assembling range: full rotation" "Grashof crank-rocker" "min 45\\.5730 deg"
             "max 132\\.1774 deg" "\n  ok\n")
# 4. solve: the swing acos(-0.1375) - acos(0.9125) = 73.7564 deg between 82.0968 and 155.853;
#    Q = 181.0672 / 178.9328 = 1.01193 (crank at acos(0.86875) and 180 + acos(0.859375) deg).
expect_run(0 solve "${file}")
expect_match("${run_output}" "stroke +73\\.7564 deg" "min +82\\.0968 deg" "max +155\\.853 deg"
             "ratio +1\\.01193" "increasing +181\\.0672 deg" "decreasing +178\\.9328 deg"
             "at_min +29\\.6863 deg" "at_max +210\\.7535 deg" "min +45\\.573 deg"
             "max +132\\.177 deg")
# 5. compare with MuJoCo, and the report.
expect_run(0 compare "${file}" --engines analytic,mujoco --report "${OUT}/my.html")
expect_match("${run_output}" "verdict: PASS")
if(NOT EXISTS "${OUT}/my.html")
  message(FATAL_ERROR "no report written")
endif()
# The report marks the rocker's dead points where step 4 locates them.
file(READ "${OUT}/my.html" page)
expect_match("${page}" "\"label\":\"dead point: angle\\.rocker min\"")
# 6. The drawing to take away, animated: the paths of B and C, the crank turning.
expect_run(0 solve "${file}" --svg "${OUT}/crank_rocker.svg" --animate 2)
file(READ "${OUT}/crank_rocker.svg" svg)
expect_match("${svg}" "<title>path of B</title>" "<title>path of C</title>"
             "<animate attributeName=\"x2\" dur=\"2s\"")
# The rule the page states: a derived name cannot be a channel kind.
string(REPLACE "name = \"TA\"" "name = \"mu\"" bad "${toml}")
file(WRITE "${OUT}/bad_name.toml" "${bad}")
expect_run(2 check "${OUT}/bad_name.toml")
expect_match("${run_output}" "bad_name\\.toml:[0-9]+:[0-9]+: error: \\[\\[derived\\]\\] name 'mu'")
