# ctest bench_rbf_smoke: `bench_rbf --quick` exits 0 and prints the CSV header and an ok row of
# every method (Open3D's only when it was found at build time).
include(${CMAKE_CURRENT_LIST_DIR}/../smoke_checks.cmake)
execute_process(COMMAND ${BENCH} --quick --threads 2 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bench_rbf --quick exited with ${rc}\n${out}\n${err}")
endif()
if(NOT out MATCHES "module,method,params,input,points,seconds")
  message(FATAL_ERROR "no CSV header\n${out}")
endif()
set(methods rbf rbf_mst pcl_poisson pcl_mc_hoppe pcl_mc_rbf)
if(HAVE_OPEN3D)
  list(APPEND methods o3d_poisson o3d_poisson_trim)
endif()
expect_method_rows("${out}" surface "[^\n]*status=ok[^\n]*,chamfer," "ok (with a chamfer distance)" ${methods})
# The noisy quick case: the defaults measure the noise and smooth (noise > 0, smoothed fits).
expect_method_rows("${out}" surface "sweep=quick;cond=noise[^\n]*status=ok[^\n]*,noise,[0-9.e-]*[1-9][^\n]*,smoothed_subdomains,[1-9]"
                   "smoothing fit on noisy input" rbf)
