# bench_idc_smoke: -DBENCH=<bench_idc> -DHAVE_OPEN3D=<bool>. --quick on the generated orbit exits
# 0 and prints a row of every method (Open3D's only where it was found); --quick on the generated
# room exits 0 and its IDC (and Open3D) rows carry a completion against the seen truth.
include(${CMAKE_CURRENT_LIST_DIR}/../smoke_checks.cmake)

# Runs bench_idc with the arguments after `row_regex` and fails unless it exits 0 and prints, for
# every method in `methods`, a row matching "surface,<method>,<row_regex>".
function(expect_rows row_regex)
  execute_process(COMMAND ${BENCH} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
    TIMEOUT 240)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "bench_idc ${ARGN}: exit ${rc}\n${out}${err}")
  endif()
  expect_method_rows("${out}" "\nsurface" "${row_regex}" "bench_idc ${ARGN} '${row_regex}'" ${methods})
endfunction()

set(methods idc idc_incremental pcl_marching_cubes_hoppe pcl_greedy_projection)
if(HAVE_OPEN3D)
  list(APPEND methods open3d_scalable_tsdf)
endif()
expect_rows("" --quick --only orbit)

set(methods idc)
if(HAVE_OPEN3D)
  list(APPEND methods open3d_scalable_tsdf)
endif()
expect_rows("[^\n]*,room-generated,[^\n]*,completion_mean,[0-9]" --quick --only room)
