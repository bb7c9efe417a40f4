# idc_scan_frames: -DAPP=<idc_scan> -DMAKE_FRAMES=<make_idc_frames> -DWORK_DIR=<dir> [-DXVFB_RUN=<xvfb-run>]
# Posed frames replayed through PCDGrabber and read as a 7-Scenes folder: a mesh must come out
# (and a screenshot where Xvfb exists); bad inputs end with exit code 1 and one line.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
include(${CMAKE_CURRENT_LIST_DIR}/../common/check_helpers.cmake)

run(${MAKE_FRAMES} --pcd-dir ${WORK_DIR}/pcd --depth-png-dir ${WORK_DIR}/depth --frames 6 --width 160 --height 120)
run(${APP} --pcd-dir ${WORK_DIR}/pcd --fps 20 --leaf 0.02 --no-window --output ${WORK_DIR}/pcd.ply)
if(NOT LAST_OUT MATCHES "frame 5/6: ")
  message(FATAL_ERROR "the app did not fuse 6 grabber frames")
endif()
require_file(${WORK_DIR}/pcd.ply)
if(XVFB_RUN)
  run(${XVFB_RUN} -a ${APP} --depth-dir ${WORK_DIR}/depth --leaf 0.02 --output ${WORK_DIR}/depth.ply
      --screenshot ${WORK_DIR}/depth.png --width 400 --height 300)
  require_file(${WORK_DIR}/depth.png)
  # The PNG has the asked size (PCL's initCameraParameters used to reset it to 640 x 512).
  file(READ ${WORK_DIR}/depth.png png_size OFFSET 16 LIMIT 8 HEX)
  if(NOT png_size STREQUAL "000001900000012c")
    message(FATAL_ERROR "depth.png is not 400 x 300 (IHDR size ${png_size})")
  endif()
else()
  run(${APP} --depth-dir ${WORK_DIR}/depth --leaf 0.02 --no-window --output ${WORK_DIR}/depth.ply)
endif()
require_file(${WORK_DIR}/depth.ply)

# Bad inputs: a missing folder, an empty frame folder, a folder without poses, a bad pose file.
file(MAKE_DIRECTORY ${WORK_DIR}/empty)
file(MAKE_DIRECTORY ${WORK_DIR}/noposes)
file(COPY ${WORK_DIR}/depth/camera-intrinsics.txt ${WORK_DIR}/depth/frame-000000.depth.png DESTINATION ${WORK_DIR}/noposes)
file(WRITE ${WORK_DIR}/bad_pose.txt "1 0 0\n")
foreach(args "--depth-dir;${WORK_DIR}/missing" "--pcd-dir;${WORK_DIR}/empty" "--depth-dir;${WORK_DIR}/noposes"
             "--pcd-dir;${WORK_DIR}/pcd;--pose;${WORK_DIR}/bad_pose.txt" "--bunny;${WORK_DIR}/empty")
  execute_process(COMMAND ${APP} ${args} --no-window RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err TIMEOUT 60)
  string(STRIP "${err}" err)
  if(NOT rc EQUAL 1 OR NOT err MATCHES "^idc_scan: " OR err MATCHES "\n")
    message(FATAL_ERROR "bad input ${args} must end with exit 1 and one line (rc ${rc}): ${err}")
  endif()
endforeach()

# A bad setting ends with exit 2 and one line, before any frame is read.
execute_process(COMMAND ${APP} --depth-dir ${WORK_DIR}/depth --max-hole-size -0.5 --no-window
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err TIMEOUT 60)
string(STRIP "${err}" err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "^idc_scan: .*--max-hole-size" OR err MATCHES "\n")
  message(FATAL_ERROR "--max-hole-size -0.5 must end with exit 2 and one line (rc ${rc}): ${err}")
endif()
