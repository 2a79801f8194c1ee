# Writes the linker dynamic list of the `vgeo` executable (tools/CMakeLists.txt): every symbol the
# vgeo_extras module leaves undefined, so the executable exports exactly the libvgeo functions the
# module calls (the rest are found in the module's own libraries). Exporting every symbol
# (-rdynamic) made .dynsym/.dynstr ~210 KB that every process start maps; a statically linked
# library's symbols would also have been exported to the libraries a process loads.
# Usage: cmake -DNM=... -DMODULE=vgeo_extras.so -DOUT=list.txt -P ModuleDynamicList.cmake
execute_process(COMMAND ${NM} -D --undefined-only ${MODULE} OUTPUT_VARIABLE undefined RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} failed on ${MODULE}")
endif()
string(REGEX MATCHALL "U [^\n@]+" entries "${undefined}")
set(text "{\n")
foreach(entry ${entries})
  string(SUBSTRING "${entry}" 2 -1 symbol)
  string(APPEND text "  ${symbol};\n")
endforeach()
string(APPEND text "};\n")
# Rewritten only when it changes: the executable relinks only when the module's needs change.
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT "${old}" STREQUAL "${text}")
  file(WRITE ${OUT} "${text}")
endif()
