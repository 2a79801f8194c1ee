# Writes the linker dynamic list of the `vgeo` executable (tools/CMakeLists.txt): every symbol the
# vgeo_extras module leaves undefined, so the executable exports exactly the libvgeo functions the
# module calls (the rest are found in the module's own libraries). Exporting every symbol
# (-rdynamic) made .dynsym/.dynstr ~210 KB that every process start maps; a statically linked
# library's symbols would also have been exported to the libraries a process loads.
# Usage: cmake -DNM=... -DMODULE=vgeo_extras.so -DOUT=list.txt -P ModuleDynamicList.cmake
include(${CMAKE_CURRENT_LIST_DIR}/DynamicSymbols.cmake)
dynamic_symbols(${NM} ${MODULE} --undefined-only U undefined)
# Only unversioned symbols: a versioned one (name@GLIBCXX_..., @PNG16_...) was bound at the
# module's link to one of its own shared libraries, which it still finds there. Exporting such a
# symbol from the executable (whose C++ runtime is a static copy) would bind the module, and any
# library loaded later (a Vulkan layer or driver), to the executable's copy of libstdc++ instead:
# two runtimes of different versions then share locale state and crash (a validation layer on a
# newer libstdc++.so than the compiler's: docs/acceptance/device_stop36.md).
set(text "{\n")
foreach(symbol ${undefined})
  if(NOT symbol MATCHES "@")
    string(APPEND text "  ${symbol};\n")
  endif()
endforeach()
string(APPEND text "};\n")
# Rewritten only when it changes: the executable relinks only when the module's needs change.
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT "${old}" STREQUAL "${text}")
  file(WRITE ${OUT} "${text}")
endif()
