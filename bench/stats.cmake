# Statistics for the benchmarking harness (Mann-Whitney, Holm, A12, aRT, Friedman, bootstrap).
# Included from bench/CMakeLists.txt: include(stats.cmake). Paths are relative to this file so
# the include works from any including directory.
find_package(Boost REQUIRED)

add_library(insid_stats ${CMAKE_CURRENT_LIST_DIR}/stats.cc)
target_include_directories(insid_stats PUBLIC ${PROJECT_SOURCE_DIR})
if(TARGET Boost::headers)
  target_link_libraries(insid_stats PRIVATE Boost::headers)
else()
  target_link_libraries(insid_stats PRIVATE Boost::boost)
endif()
target_link_libraries(insid_stats PRIVATE insid_options)

if(INSID_BUILD_TESTS)
  add_executable(insid_stats_tests ${CMAKE_CURRENT_LIST_DIR}/stats_test.cc)
  target_link_libraries(insid_stats_tests PRIVATE insid_stats insid_options GTest::gtest_main)
  gtest_discover_tests(insid_stats_tests DISCOVERY_TIMEOUT 60)
endif()
