# cmake -DCROSSLINK=exe -DCHROMIUM=browser -DMECHANISM=file -DOUT=dir [-DAT=value] [-DENGINES=list]
#       [-DSUBCOMMAND=compare|sweep] [-DLAYOUT=ON] -P browser_test.cmake
# Writes the HTML report of MECHANISM (`crosslink compare`, or SUBCOMMAND's), opens it in
# headless Chromium, and fails unless the page's own status element says every chart rendered
# with no script error. Keeps the report, the dumped DOM, the browser log and a screenshot in OUT
# as artifacts.
file(MAKE_DIRECTORY "${OUT}")
set(report "${OUT}/report.html")
set(at_args)
if(DEFINED AT)
  set(at_args --at ${AT})
endif()
if(DEFINED ENGINES)
  list(APPEND at_args --engines ${ENGINES})
endif()
if(NOT DEFINED SUBCOMMAND)
  set(SUBCOMMAND compare)
endif()
# MECHANISM may be a list (a sweep of several definitions: a status per section, all checked).
execute_process(COMMAND "${CROSSLINK}" ${SUBCOMMAND} ${MECHANISM} --report "${report}" ${at_args}
                RESULT_VARIABLE code OUTPUT_QUIET)
if(NOT EXISTS "${report}" OR code GREATER 1)
  message(FATAL_ERROR "crosslink ${SUBCOMMAND} --report failed (exit ${code})")
endif()
# With -DLAYOUT=ON, the layout rules of docs/report.md ("How it is tested") are measured in the
# rendered page by report_layout_check.js, appended to a copy of the report that is opened
# instead (one browser run serves both checks).
set(opened "${report}")
if(LAYOUT)
  file(READ "${report}" page)
  file(READ "${CMAKE_CURRENT_LIST_DIR}/report_layout_check.js" checker)
  string(FIND "${page}" "</body>" body_end REVERSE)
  string(SUBSTRING "${page}" 0 ${body_end} page)
  set(opened "${OUT}/report.checked.html")
  file(WRITE "${opened}" "${page}<script>\n${checker}\n</script>\n</body>\n</html>\n")
endif()
set(flags --headless --no-sandbox --disable-gpu --disable-background-networking
          --disable-component-update --no-first-run --user-data-dir=${OUT}/profile
          --enable-logging=stderr --v=0 --virtual-time-budget=20000)
execute_process(COMMAND "${CHROMIUM}" ${flags} --window-size=1200,3000 --dump-dom
                        "file://${opened}"
                OUTPUT_VARIABLE dom ERROR_VARIABLE log TIMEOUT 120)
file(WRITE "${OUT}/report.dom.html" "${dom}")
file(WRITE "${OUT}/chromium.log" "${log}")
execute_process(COMMAND "${CHROMIUM}" ${flags} --window-size=1200,3000
                        --screenshot=${OUT}/report.png "file://${report}"
                OUTPUT_QUIET ERROR_QUIET TIMEOUT 120)
string(REPLACE ";" "," flat "${dom}")  # a status's text may hold a ';', a CMake list's separator
string(REGEX MATCHALL "<p id=\"[a-z0-9]*-?render-status\"[^>]*>[^<]*</p>" statuses "${flat}")
if(NOT statuses)
  message(FATAL_ERROR "the report has no render status\nbrowser log: ${OUT}/chromium.log")
endif()
foreach(status IN LISTS statuses)
  message("status: ${status}")
  if(NOT status MATCHES "data-status=\"ok\"")
    message(FATAL_ERROR "the report did not render: ${status}\nbrowser log: ${OUT}/chromium.log")
  endif()
endforeach()
# Console errors from the page (uncaught exceptions are already in the status).
string(REGEX MATCHALL "CONSOLE\\([0-9]+\\)\\][^\n]*" console "${log}")
foreach(line IN LISTS console)
  if(line MATCHES "[Ee]rror")
    message(FATAL_ERROR "console error: ${line}")
  endif()
endforeach()
if(NOT EXISTS "${OUT}/report.png")
  message(FATAL_ERROR "no screenshot")
endif()
message("screenshot: ${OUT}/report.png")

# The layout rules, as report_layout_check.js measured them.
if(NOT LAYOUT)
  return()
endif()
string(REGEX MATCH "<pre id=\"layout-check\">([^<]*)</pre>" _ "${dom}")
set(measured "${CMAKE_MATCH_1}")
string(REPLACE "&quot;" "\"" measured "${measured}")
string(REPLACE "&lt;" "<" measured "${measured}")
string(REPLACE "&gt;" ">" measured "${measured}")
string(REPLACE "&amp;" "&" measured "${measured}")
file(WRITE "${OUT}/layout.json" "${measured}\n")
message("layout: ${measured}")
if(measured STREQUAL "")
  message(FATAL_ERROR "the layout check wrote nothing")
endif()
# ERROR_VARIABLE is NOTFOUND when the member exists: the check itself threw.
string(JSON error ERROR_VARIABLE no_error GET "${measured}" error)
if(NOT no_error)
  message(FATAL_ERROR "the layout check failed to run: ${error}")
endif()
string(JSON n LENGTH "${measured}" failures)
if(n GREATER 0)
  math(EXPR last "${n} - 1")
  set(lines)
  foreach(i RANGE ${last})
    string(JSON line GET "${measured}" failures ${i})
    string(APPEND lines "\n  ${line}")
  endforeach()
  message(FATAL_ERROR "the report breaks ${n} layout rules (${OUT}/layout.json):${lines}")
endif()
