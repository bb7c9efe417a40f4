# pclx_pipeline end to end: posed PCD frames through every stage off-screen (screenshot, each
# stage's output, per-frame timings), the 7-Scenes layout with RBF-POU keyframes, stages
# switched off, and a bad input (exit 1 with a message).
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
include(${CMAKE_CURRENT_LIST_DIR}/../common/check_helpers.cmake)

run(${MAKE_FRAMES} --pcd-dir ${WORK_DIR}/frames --depth-png-dir ${WORK_DIR}/depth --frames 6 --width 320 --height 240)
run(${XVFB_RUN} -a ${APP} --pcd-dir ${WORK_DIR}/frames --fps 20 --screenshot ${WORK_DIR}/pipeline.png
    --output ${WORK_DIR}/out --timings ${WORK_DIR}/timings.csv --octree-every 2)
expect("all stages" "frame 5: filter [0-9.]+ ms, hpr [0-9.]+ ms, normals [0-9.]+ ms, surface [0-9.]+ ms, octree [0-9.]+ ms")
expect("all stages" "frame 5:.* [1-9][0-9]* after the voxel grid and HPR, [1-9][0-9]* mesh triangles, [1-9][0-9]* in the map")
expect("summary" "slowest stage: (filter|hpr|normals|surface|octree)")
foreach(f timings.csv out/filtered.pcd out/visible.pcd out/normals.pcd out/map.pcd out/surface.ply
          out/potree/metadata.json)
  require_file(${WORK_DIR}/${f} 100)
endforeach()
require_file(${WORK_DIR}/pipeline.png 20000)
file(STRINGS ${WORK_DIR}/timings.csv rows)
list(LENGTH rows n)
if(NOT n EQUAL 7)
  message(FATAL_ERROR "timings.csv: ${n} lines, expected a header and 6 frames")
endif()

# The 7-Scenes layout (poses from .pose.txt), RBF-POU on keyframes, HPR and the octree off.
run(${XVFB_RUN} -a ${APP} --depth-dir ${WORK_DIR}/depth --fps 20 --surface rbf --keyframe 3 --no-hpr --no-octree
    --screenshot ${WORK_DIR}/rbf.png)
expect("rbf" "frame 5: filter [0-9.]+ ms, hpr 0.0 ms, normals [0-9.]+ ms, surface [0-9.]+ ms, octree 0.0 ms")
expect("rbf" "frame 3:.* [1-9][0-9]* mesh triangles")

# A missing folder is an error exit with a message, not a crash.
execute_process(COMMAND ${APP} --pcd-dir ${WORK_DIR}/missing RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "pclx_pipeline: ")
  message(FATAL_ERROR "a missing frame folder must fail with a message (rc ${rc}): ${err}")
endif()
