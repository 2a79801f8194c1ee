# Installs the built vgeo into a scratch prefix, then configures, builds and runs the
# consumer project against it.
set(prefix ${VGEO_BUILD_DIR}/consumer-test/prefix)
set(build ${VGEO_BUILD_DIR}/consumer-test/build)
file(REMOVE_RECURSE ${VGEO_BUILD_DIR}/consumer-test)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${VGEO_BUILD_DIR} --prefix ${prefix}
  RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${build} -DCMAKE_PREFIX_PATH=${prefix}
  RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "consumer configure failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${build} RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "consumer build failed: ${rc}")
endif()
execute_process(COMMAND ${build}/consumer RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "consumer run failed: ${rc}")
endif()
