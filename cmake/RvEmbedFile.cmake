# cmake -DINPUT=file -DOUTPUT=file.cpp -DSYMBOL=ns::name -P RvEmbedFile.cmake
# Writes a C++ source defining `const char* const SYMBOL` and `SYMBOL##Size` with the file's
# bytes, so that the binary serves exactly the document that is in the repository.
file(READ "${INPUT}" content HEX)
string(LENGTH "${content}" hex_length)
math(EXPR size "${hex_length} / 2")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "'\\\\x\\1'," bytes "${content}")
string(REGEX REPLACE "::[^:]*$" "" ns "${SYMBOL}")
string(REGEX REPLACE "^.*::" "" name "${SYMBOL}")
file(WRITE "${OUTPUT}.tmp"
  "// Generated from ${INPUT} by RvEmbedFile.cmake. Do not edit.\n#include <cstddef>\n"
  "namespace ${ns} {\nnamespace { const char kBytes[] = {${bytes} '\\0'}; }\n"
  "extern const char* const ${name};\nextern const std::size_t ${name}Size;\n"
  "const char* const ${name} = kBytes;\nconst std::size_t ${name}Size = ${size};\n}\n")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
