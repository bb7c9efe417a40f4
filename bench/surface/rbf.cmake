# bench_rbf: pcl::RBFPOUReconstruction, the whole pipeline (our normals + MST, PCA
# normals + MST, true normals) against PCL Poisson, MarchingCubesHoppe, MarchingCubesRBF and,
# when found, Open3D's screened Poisson. Every method runs in a forked child (peak memory,
# address-space and time limits); see bench_rbf.cpp.
add_executable(bench_rbf bench_rbf.cpp bench_rbf_metrics.cpp)
target_link_libraries(bench_rbf PRIVATE pclx_surface pclx_normals pclx_testing pclx_bench_common CLI11::CLI11
  pcl_surface pcl_features pcl_kdtree pcl_search OpenMP::OpenMP_CXX)
target_compile_options(bench_rbf PRIVATE -Wall -Wextra)
find_package(Open3D QUIET)
if(Open3D_FOUND)
  # Open3D's headers stay in their own translation unit (their Eigen settings; see bench/normals).
  target_sources(bench_rbf PRIVATE bench_rbf_open3d.cpp)
  target_link_libraries(bench_rbf PRIVATE Open3D::Open3D)
  target_compile_definitions(bench_rbf PRIVATE PCLX_HAVE_OPEN3D)
else()
  message(STATUS "bench_rbf: Open3D not found, its peer rows are skipped")
endif()

# Smoke test: --quick on a tiny cloud exits 0 and prints the header and a row of every method.
if(PCLX_BUILD_TESTS)
  add_test(NAME bench_rbf_smoke
    COMMAND ${CMAKE_COMMAND} -DBENCH=$<TARGET_FILE:bench_rbf> -DHAVE_OPEN3D=${Open3D_FOUND}
      -P ${CMAKE_CURRENT_SOURCE_DIR}/rbf_smoke.cmake)
  set_tests_properties(bench_rbf_smoke PROPERTIES TIMEOUT 60)
endif()
