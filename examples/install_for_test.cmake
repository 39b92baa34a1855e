# cmake -DBUILD_DIR=... -DPREFIX=... -P install_for_test.cmake
file(REMOVE_RECURSE ${PREFIX})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX} RESULT_VARIABLE rc
                OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}); build every target first")
endif()
foreach(f lib/cmake/hexsim/hexsimConfig.cmake include/hexsim/sim/simulation.h share/hexsim/worlds/missions/square.yaml)
  if(NOT EXISTS ${PREFIX}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
