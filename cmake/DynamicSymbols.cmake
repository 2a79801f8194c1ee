# dynamic_symbols(NM FILE WHICH TYPES OUT): the names in FILE's dynamic symbol table that
# `nm -D WHICH` lists (WHICH: --defined-only or --undefined-only) with a type letter matching the
# regex TYPES ("U": strong undefined only, "[A-Za-z]": any), each as nm prints it, a version
# suffix (name@VERSION, name@@VERSION) included. Used by ModuleDynamicList.cmake and
# tests/cli/no_runtime_exports.cmake.
function(dynamic_symbols nm file which types out)
  execute_process(COMMAND ${nm} -D ${which} ${file} OUTPUT_VARIABLE text RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${nm} -D ${which} failed on ${file}")
  endif()
  string(REPLACE "\n" ";" lines "${text}")
  set(names "")
  foreach(line ${lines})
    if(line MATCHES " ${types} ([^ ]+)$")
      list(APPEND names "${CMAKE_MATCH_1}")
    endif()
  endforeach()
  set(${out} "${names}" PARENT_SCOPE)
endfunction()
