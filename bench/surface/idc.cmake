# Incremental dual contouring: the front end per frame (bench_idc_frontend) and the
# whole pipeline against Open3D's ScalableTSDFVolume and PCL's MarchingCubesHoppe /
# GreedyProjectionTriangulation (bench_idc).
# The 7-Scenes reader is pclx_appkit's (apps/common), built with the apps.
if(NOT PCLX_BUILD_APPS)
  message(STATUS "bench idc: PCLX_BUILD_APPS is off (pclx_appkit needed), bench_idc* skipped")
  return()
endif()
add_executable(bench_idc_frontend ${CMAKE_CURRENT_LIST_DIR}/bench_idc_frontend.cpp)
target_link_libraries(bench_idc_frontend PRIVATE pclx_surface pclx_testing pclx_appkit pclx_bench_common CLI11::CLI11)

# bench_idc reuses bench_rbf's mesh metrics (two-sided CGAL distances, weld, topology).
add_executable(bench_idc ${CMAKE_CURRENT_LIST_DIR}/bench_idc.cpp ${CMAKE_CURRENT_LIST_DIR}/bench_rbf_metrics.cpp)
target_include_directories(bench_idc PRIVATE ${CMAKE_CURRENT_LIST_DIR})
target_link_libraries(bench_idc PRIVATE pclx_surface pclx_testing pclx_appkit pclx_bench_common CLI11::CLI11
  pcl_surface pcl_features pcl_filters pcl_kdtree pcl_search)
find_package(Open3D QUIET)
if(Open3D_FOUND)
  target_sources(bench_idc PRIVATE ${CMAKE_CURRENT_LIST_DIR}/bench_idc_open3d.cpp)
  target_link_libraries(bench_idc PRIVATE Open3D::Open3D)
  target_compile_definitions(bench_idc PRIVATE PCLX_HAVE_OPEN3D)
else()
  message(STATUS "bench_idc: Open3D not found, its peer rows are skipped")
endif()

if(PCLX_BUILD_TESTS)
  add_test(NAME bench_idc_smoke
    COMMAND ${CMAKE_COMMAND} -DBENCH=$<TARGET_FILE:bench_idc> -DHAVE_OPEN3D=${Open3D_FOUND}
      -P ${CMAKE_CURRENT_SOURCE_DIR}/idc_smoke.cmake)
  set_tests_properties(bench_idc_smoke PROPERTIES TIMEOUT 300)
endif()
