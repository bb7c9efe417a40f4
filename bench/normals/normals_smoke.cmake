# ctest bench_normals_smoke: `bench_normals --quick` exits 0 and prints the CSV header and a row
# of every method (Open3D's and CGAL's only when they were found at build time).
include(${CMAKE_CURRENT_LIST_DIR}/../smoke_checks.cmake)
execute_process(COMMAND ${BENCH} --quick --threads 2 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bench_normals --quick exited with ${rc}\n${out}\n${err}")
endif()
if(NOT out MATCHES "module,method,params,input,points,seconds")
  message(FATAL_ERROR "no CSV header\n${out}")
endif()
set(methods ours pca_k18 oracle_pca orient_mst_ours pcl_omp_k18 pca_oracle)
if(HAVE_OPEN3D)
  list(APPEND methods open3d_k18 open3d_hybrid)
endif()
if(HAVE_CGAL)
  list(APPEND methods jet_k18 jet_best vcm_best)
endif()
expect_method_rows("${out}" normals "[^\n]*,(rms|flipped)," "error-metric" ${methods})
# Speed rows carry the process CPU time of the call and the repeat count after the error metrics.
expect_method_rows("${out}" normals "sweep=speed;[^\n]*,rms,[^\n]*,cpu_seconds,[0-9.e+-]+,repeats,2\n"
  "speed (ending with cpu_seconds and repeats)" ours pcl_omp_k18 pca_oracle)
# --orient: the orientation oracle rows. On a noisy cube a reader that knows the true surface
# gets every sign right from the position alone (the bisector of two faces at an edge).
execute_process(COMMAND ${BENCH} --orient --quick --threads 2 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bench_normals --orient --quick exited with ${rc}\n${out}\n${err}")
endif()
expect_method_rows("${out}" normals "sweep=orient;noise=0.006,grooved_slab,[^\n]*,flipped,"
  "noisy grooved slab" orient_oracle_position orient_oracle_ours_lines)
if(NOT out MATCHES "normals,orient_oracle_position,sweep=orient;noise=0.006,cube,[0-9]+,[^,]*,flipped,0\n")
  message(FATAL_ERROR "the position oracle flips normals on a noisy cube\n${out}")
endif()
