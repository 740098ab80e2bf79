# A text file (a page script, a starting definition) embedded in a C++ source at build time (the
# chart libraries are read at run time). Included (top-level CMakeLists.txt), it defines
#   crosslink_embed_text(<var> <file> <symbol> <namespace>)
# which sets <var> to the generated source defining `const char* const crosslink::<namespace>::
# <symbol>` with the file's text; the build then runs this same file as a script (-P) to write it.
if(NOT CMAKE_SCRIPT_MODE_FILE)
  set(_crosslink_embed_script ${CMAKE_CURRENT_LIST_FILE})
  function(crosslink_embed_text var input symbol namespace)
    get_filename_component(name ${input} NAME_WE)
    set(source ${CMAKE_CURRENT_BINARY_DIR}/${name}_embedded.cpp)
    add_custom_command(
      OUTPUT ${source}
      COMMAND ${CMAKE_COMMAND} -DINPUT=${input} -DOUTPUT=${source} -DSYMBOL=${symbol}
              -DNAMESPACE=${namespace} -P ${_crosslink_embed_script}
      DEPENDS ${input} ${_crosslink_embed_script}
      COMMENT "Embedding ${name}")
    set(${var} ${source} PARENT_SCOPE)
  endfunction()
  return()
endif()

file(READ "${INPUT}" text)
string(FIND "${text}" ")crosslink_text\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT} contains the raw-string delimiter")
endif()
file(WRITE "${OUTPUT}.tmp"
  "// Generated from ${INPUT} by embed_text.cmake; do not edit.\n"
  "namespace crosslink::${NAMESPACE} {\n"
  "extern const char* const ${SYMBOL};\n"
  "const char* const ${SYMBOL} = R\"crosslink_text(${text})crosslink_text\";\n"
  "}  // namespace crosslink::${NAMESPACE}\n")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
