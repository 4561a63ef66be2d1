# Line hop benchmark (included by tools/benchmarks/CMakeLists.txt with MOTION_BUILD_BENCH): the time
# from a write() to the reading process's read, over a simulated serial line (pty) and a simulated
# CAN link (AF_UNIX socket), against each other. A plain main printing one table.
add_executable(bench_line_hop ${CMAKE_CURRENT_LIST_DIR}/line_hop_bench.cpp)
target_link_libraries(bench_line_hop PRIVATE motion::warnings motion::serial Threads::Threads)
set_target_properties(bench_line_hop PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
