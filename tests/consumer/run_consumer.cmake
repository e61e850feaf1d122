# Runs one consumer test: MODE=find_package installs mpskit into a prefix first; MODE=add_subdirectory
# adds the source tree. Configures, builds and runs the consumer program; any failure fails the test.
# CONSUMER_CXX_FLAGS / CONSUMER_LINKER_FLAGS (the calling build's CMAKE_CXX_FLAGS and CMAKE_EXE_LINKER_FLAGS, may be
# empty) are passed to the consumer project, and to mpskit's own configure before the install.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
set(consumer_dir ${CMAKE_CURRENT_LIST_DIR}/${MODE})
set(flags "-DCMAKE_CXX_FLAGS=${CONSUMER_CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_LINKER_FLAGS}")
if(MODE STREQUAL "find_package")
  run(${CMAKE_COMMAND} -S ${MPSKIT_SOURCE_DIR} -B ${WORK_DIR}/mpskit-build -DMPSKIT_BUILD_TESTS=OFF
      -DMPSKIT_BUILD_EXAMPLES=OFF -DCMAKE_INSTALL_PREFIX=${WORK_DIR}/prefix ${flags})
  run(${CMAKE_COMMAND} --install ${WORK_DIR}/mpskit-build)
  run(${CMAKE_COMMAND} -S ${consumer_dir} -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
      -DCMAKE_BUILD_TYPE=Release ${flags})
else()
  run(${CMAKE_COMMAND} -S ${consumer_dir} -B ${WORK_DIR}/build -DMPSKIT_SOURCE_DIR=${MPSKIT_SOURCE_DIR}
      -DCMAKE_BUILD_TYPE=Release ${flags})
endif()
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
