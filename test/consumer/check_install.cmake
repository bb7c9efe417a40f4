# Installs the pclx build tree into a scratch prefix, then configures, builds and runs
# test/consumer and examples/ against it with find_package(pclx).
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${PCLX_BINARY_DIR} --prefix ${prefix})
run(${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${WORK_DIR}/build -G Ninja
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)

# The examples, as a newcomer builds them (no build type: the quickest compile); each runs on
# its generated input and checks its own result.
set(examples hpr_filter planar_octree_normal_estimation mst_normal_orientation oblique_cut_octree
    incremental_dual_contouring rbf_pou_reconstruction)
run(${CMAKE_COMMAND} -S ${EXAMPLES_SOURCE_DIR} -B ${WORK_DIR}/examples -G Ninja -DCMAKE_PREFIX_PATH=${prefix})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/examples)
file(MAKE_DIRECTORY ${WORK_DIR}/examples_run)
foreach(example ${examples})
  execute_process(COMMAND ${WORK_DIR}/examples/${example} WORKING_DIRECTORY ${WORK_DIR}/examples_run
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "examples/${example} failed (${rc}):\n${out}")
  endif()
  message(STATUS "examples/${example}: ${out}")
endforeach()
