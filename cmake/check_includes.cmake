# cmake -DDIR=<folder> -DFORBIDDEN="sim/;methods/" -P check_includes.cmake
# cmake -DFILES="a.cpp;a.h" -DDIR=<name> -DFORBIDDEN=... -P check_includes.cmake
# Fails when a source or header under DIR (or one of FILES) includes a header from a FORBIDDEN
# folder or a FORBIDDEN header.
if(FILES)
  set(_files ${FILES})
else()
  file(GLOB_RECURSE _files "${DIR}/*.h" "${DIR}/*.cpp")
endif()
set(_bad "")
foreach(_file IN LISTS _files)
  foreach(_folder IN LISTS FORBIDDEN)
    file(STRINGS "${_file}" _lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<]${_folder}")
    foreach(_line IN LISTS _lines)
      string(APPEND _bad "\n  ${_file}: ${_line}")
    endforeach()
  endforeach()
endforeach()
if(_bad)
  message(FATAL_ERROR "${DIR} includes from ${FORBIDDEN}:${_bad}")
endif()
list(LENGTH _files _count)
message("${_count} files under ${DIR} include nothing from ${FORBIDDEN}")
