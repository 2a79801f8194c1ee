# cmake -DSPV=in.spv -DOUT=out.cpp -DNAME=kShaderFoo -DLABEL=foo -DSOURCE=foo.comp -P EmbedSpirv.cmake
# Turns one SPIR-V binary into a C++ array (lib/vgeo/gpu/context.h ShaderBinary), so the
# library never looks shaders up on disk at run time.
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" n)
math(EXPR words "${n} / 8")
set(body "")
set(i 0)
while(i LESS n)
  # SPIR-V is a little-endian word stream: bytes b0 b1 b2 b3 → word 0xb3b2b1b0.
  string(SUBSTRING "${hex}" ${i} 8 w)
  string(SUBSTRING "${w}" 0 2 b0)
  string(SUBSTRING "${w}" 2 2 b1)
  string(SUBSTRING "${w}" 4 2 b2)
  string(SUBSTRING "${w}" 6 2 b3)
  string(APPEND body "0x${b3}${b2}${b1}${b0}u,")
  math(EXPR i "${i} + 8")
  math(EXPR col "(${i} / 8) % 8")
  if(col EQUAL 0)
    string(APPEND body "\n")
  endif()
endwhile()
file(WRITE ${OUT} "// Generated from ${SOURCE} by cmake/EmbedSpirv.cmake. Do not edit.\n"
  "#include \"vgeo/gpu/shaders.h\"\nnamespace vgeo {\nnamespace {\nconst uint32_t kWords[] = {\n${body}};\n}  // namespace\n"
  "const ShaderBinary ${NAME} = {\"${LABEL}\", kWords, ${words}};\n}  // namespace vgeo\n")
