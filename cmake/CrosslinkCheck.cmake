# crosslink_add_check(NAME FILE [ENGINES method...] [TOLERANCE class=percent...]
#                     [SETTINGS key=value...] [LABELS label...] [ARGS arg...])
#
# Registers a ctest case that runs `crosslink compare FILE` and passes when every verdict passes
# (exit 0; 1 = a failed verdict, 2 = bad input or nothing judged). Its verdicts include each
# [[reference]] row the file gives a `tolerance` (docs/mechanism-format.md). Labels: crossval plus
# LABELS.
#   ENGINES    methods to compare against the exact sweep (default: all built in): analytic dyads
#              ic and every engine (`crosslink engines`)
#   TOLERANCE  verdict tolerances in % of peak, "velocity=0.5" (engines) or
#              "dyads:velocity=1e-6" (one method); the file's [tolerance] table applies first
#   SETTINGS   engine settings "dt=1e-4" or "mujoco:dt=1e-4"
# FILE is relative to the calling CMakeLists.txt's folder. Available in the build tree of
# crosslink and, after find_package(crosslink), in any project.
function(crosslink_add_check name file)
  cmake_parse_arguments(CHECK "" "" "ENGINES;TOLERANCE;SETTINGS;LABELS;ARGS" ${ARGN})
  if(CHECK_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "crosslink_add_check(${name}): unknown arguments ${CHECK_UNPARSED_ARGUMENTS}")
  endif()
  cmake_path(ABSOLUTE_PATH file BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}")
  set(command compare "${file}")
  if(CHECK_ENGINES)
    list(JOIN CHECK_ENGINES "," engines)
    list(APPEND command --engines ${engines})
  endif()
  foreach(tolerance IN LISTS CHECK_TOLERANCE)
    list(APPEND command --tolerance ${tolerance})
  endforeach()
  foreach(setting IN LISTS CHECK_SETTINGS)
    list(APPEND command --set ${setting})
  endforeach()
  add_test(NAME ${name} COMMAND $<TARGET_FILE:crosslink::crosslink> ${command} ${CHECK_ARGS})
  set_tests_properties(${name} PROPERTIES LABELS "crossval;${CHECK_LABELS}")
endfunction()
