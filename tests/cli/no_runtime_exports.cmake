# The `vgeo` executable exports no symbol that the shared C++ runtime (libstdc++.so) defines.
# The executable links libstdc++ statically (tools/CMakeLists.txt); an exported runtime symbol
# (a function, or a locale facet's id, which the linker exports as STB_GNU_UNIQUE) binds every
# library loaded later to the executable's copy. A Vulkan validation layer built against a newer
# libstdc++.so then mixes two runtimes' locale tables and crashes on its first formatted number
# (seen on an NVIDIA driver under Ubuntu 24.04 with a Debian 12 build:
# docs/acceptance/device_stop36.md).
# Usage: cmake -DNM=nm -DEXE=bin/vgeo -DRUNTIME=libstdc++.so.6 -P no_runtime_exports.cmake
foreach(var NM EXE RUNTIME)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "no_runtime_exports.cmake: -D${var}= missing")
  endif()
endforeach()
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/DynamicSymbols.cmake)
dynamic_symbols(${NM} ${EXE} --defined-only "[A-Za-z]" exported)
dynamic_symbols(${NM} ${RUNTIME} --defined-only "[A-Za-z]" versioned)
set(runtime "")
foreach(symbol ${versioned})
  string(REGEX REPLACE "@.*" "" symbol "${symbol}")
  list(APPEND runtime "${symbol}")
endforeach()
list(LENGTH runtime runtime_count)
if(runtime_count LESS 1000)
  message(FATAL_ERROR "${RUNTIME}: only ${runtime_count} dynamic symbols read; not the C++ runtime?")
endif()
set(shared "")
foreach(name ${exported})
  list(FIND runtime "${name}" at)
  if(NOT at EQUAL -1)
    list(APPEND shared "${name}")
  endif()
endforeach()
list(LENGTH shared count)
if(count GREATER 0)
  list(SUBLIST shared 0 5 first)
  message(FATAL_ERROR "${EXE} exports ${count} symbol(s) of the C++ runtime, e.g. ${first}")
endif()
message(STATUS "${EXE}: no C++ runtime symbol exported (${runtime_count} runtime symbols checked)")
