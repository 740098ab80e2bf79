# cmake -DBUILD_DIR=dir -DWORK=dir -DCONSUMER=dir -DMECHANISM=file -P package_test.cmake
# Installs crosslink into a temporary prefix, configures a small consumer project that calls
# find_package(crosslink) and crosslink_add_check(), and runs the consumer's tests: the installed
# package must work on its own, so packaging cannot rot (after fmt's find-package-test).
file(REMOVE_RECURSE "${WORK}")
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}${err}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "failed (${code}): ${ARGN}")
  endif()
  set(output "${out}${err}" PARENT_SCOPE)
endfunction()
run(${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK}/prefix")
run(${CMAKE_COMMAND} -S "${CONSUMER}" -B "${WORK}/build" "-DCMAKE_PREFIX_PATH=${WORK}/prefix"
    "-DMECHANISM=${MECHANISM}")
run(ctest --test-dir "${WORK}/build" --output-on-failure -L crossval -V)
if(NOT output MATCHES "${WORK}/prefix/bin/crosslink")
  message(FATAL_ERROR "the consumer's test did not run the installed crosslink")
endif()
if(NOT output MATCHES "100% tests passed")
  message(FATAL_ERROR "the consumer's check did not pass")
endif()
# The Python module, when built, installs under the prefix too and imports from there alone (no
# semicolon in the code: run() takes its arguments as a list).
file(GLOB _modules "${WORK}/prefix/lib/python*/dist-packages/crosslink*.so")
if(_modules AND EXISTS /usr/bin/python3)
  get_filename_component(_site "${_modules}" DIRECTORY)
  run(${CMAKE_COMMAND} -E chdir "${WORK}" ${CMAKE_COMMAND} -E env "PYTHONPATH=${_site}"
      /usr/bin/python3 -c
      "import crosslink\nprint(crosslink.__file__, crosslink.load('${MECHANISM}').name)")
  if(NOT output MATCHES "${WORK}/prefix/lib/python")
    message(FATAL_ERROR "the installed Python module was not the one imported")
  endif()
endif()
