# rbf_reconstruct_demo: -DAPP=<rbf_reconstruct> -DWORK_DIR=<dir> [-DXVFB_RUN=<xvfb-run>]
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

# A torus with true normals: a mesh file must come out.
execute_process(COMMAND ${APP} --demo torus --points 8000 --output ${WORK_DIR}/torus.ply
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK_DIR}/torus.ply)
  message(FATAL_ERROR "demo torus: exit ${rc}, no ${WORK_DIR}/torus.ply")
endif()
file(SIZE ${WORK_DIR}/torus.ply size)
if(size LESS 1000)
  message(FATAL_ERROR "demo torus: torus.ply has only ${size} bytes")
endif()

# The off-screen window path (only where xvfb-run exists).
if(XVFB_RUN)
  execute_process(COMMAND ${XVFB_RUN} -a ${APP} --demo sphere --points 4000 --screenshot ${WORK_DIR}/sphere.png
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK_DIR}/sphere.png)
    message(FATAL_ERROR "screenshot: exit ${rc}\n${out}${err}")
  endif()
endif()

# An empty .pcd: the loader's one-line error and exit code 1 (not a crash).
file(WRITE ${WORK_DIR}/empty.pcd "")
execute_process(COMMAND ${APP} ${WORK_DIR}/empty.pcd --output ${WORK_DIR}/empty.ply
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(STRIP "${err}" err)
if(NOT rc EQUAL 1 OR err MATCHES "\n" OR NOT err MATCHES "^rbf_reconstruct: ")
  message(FATAL_ERROR "empty.pcd: exit ${rc}, stderr:\n${err}")
endif()
