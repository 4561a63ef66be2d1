# ADAM Modbus RTU line benchmark (included by tools/benchmarks/CMakeLists.txt with MOTION_BUILD_BENCH):
# poll cycle for N = 1, 8, 32 drives at 115200 and 19200 baud and command latency while polling,
# each against the wire-time bound of the same frames. A plain main printing one table.
add_executable(bench_adam ${CMAKE_CURRENT_LIST_DIR}/adam_bench.cpp)
target_link_libraries(bench_adam PRIVATE motion::warnings motion::sim_adam motion::adam_driver Threads::Threads)
set_target_properties(bench_adam PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
