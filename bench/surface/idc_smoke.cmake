# bench_idc_smoke: -DBENCH=<bench_idc> -DHAVE_OPEN3D=<bool>. --quick on the generated orbit exits
# 0 and prints a row of every method (Open3D's only where it was found); --quick on the generated
# room exits 0 and its IDC (and Open3D) rows carry a completion against the seen truth.
execute_process(COMMAND ${BENCH} --quick --only orbit RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
  TIMEOUT 240)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bench_idc --quick: exit ${rc}\n${out}${err}")
endif()
set(methods idc idc_incremental pcl_marching_cubes_hoppe pcl_greedy_projection)
if(HAVE_OPEN3D)
  list(APPEND methods open3d_scalable_tsdf)
endif()
foreach(m ${methods})
  if(NOT out MATCHES "\nsurface,${m},")
    message(FATAL_ERROR "bench_idc --quick printed no ${m} row:\n${out}")
  endif()
endforeach()

execute_process(COMMAND ${BENCH} --quick --only room RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
  TIMEOUT 240)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bench_idc --quick --only room: exit ${rc}\n${out}${err}")
endif()
set(methods idc)
if(HAVE_OPEN3D)
  list(APPEND methods open3d_scalable_tsdf)
endif()
foreach(m ${methods})
  if(NOT out MATCHES "\nsurface,${m},[^\n]*,room-generated,[^\n]*,completion_mean,[0-9]")
    message(FATAL_ERROR "bench_idc --quick --only room printed no ${m} row with completion_mean:\n${out}")
  endif()
endforeach()
