# Simulated CAN bus benchmark (included by tools/benchmarks/CMakeLists.txt with MOTION_BUILD_BENCH).
# A plain main printing one table (see the header of simbus_bench.cpp for why not Google Benchmark).
add_executable(bench_simbus ${CMAKE_CURRENT_LIST_DIR}/simbus_bench.cpp ${CMAKE_CURRENT_LIST_DIR}/simbus_bench_links.cpp)
target_link_libraries(bench_simbus PRIVATE motion::warnings motion::simbus Threads::Threads)
set_target_properties(bench_simbus PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
