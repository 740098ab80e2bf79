# cmake -DINPUT=file -DOUTPUT=file.cpp -DSYMBOL=name [-DNAMESPACE=methods] -P embed_text.cmake
# Writes a C++ source defining `const char* const crosslink::NAMESPACE::SYMBOL` (default
# namespace: compare) with INPUT's text.
if(NOT NAMESPACE)
  set(NAMESPACE compare)
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
