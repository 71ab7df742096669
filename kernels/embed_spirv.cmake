# Writes the SPIR-V words of ${SPV} as a C++ array named photosite_spv_${NAME} into ${OUT}.
# SPIR-V files are little-endian words here (glslang writes host order; every Vulkan host we
# target is little-endian): bytes b0 b1 b2 b3 → 0xb3b2b1b0.
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" n)
math(EXPR words "${n} / 8")
string(REGEX REPLACE "(..)(..)(..)(..)" "0x\\4\\3\\2\\1u,\n" body "${hex}")
file(WRITE ${OUT} "// Generated from ${NAME}.spv by kernels/embed_spirv.cmake; do not edit.\n#include <cstddef>\n#include <cstdint>\nextern const uint32_t photosite_spv_${NAME}[] = {\n${body}};\nextern const size_t photosite_spv_${NAME}_words = ${words};\n")
