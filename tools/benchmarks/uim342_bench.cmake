# UIM342 (SimpleCAN 3.0) benchmark (included by tools/benchmarks/CMakeLists.txt with
# MOTION_BUILD_BENCH): LCM command -> first frame (bus timing off) against a raw LCM hop, arm +
# trigger of N = 2/8/32 grouped axes against the wire time of the move's frames, and status
# updates/s for N = 8/32/120 axes against the bus capacity, all measured in the same run, the
# Uim342Stack and the simulated drives on one in-process simbus hub. A plain main printing one
# table (see the header of uim342_bench.cpp). Run: tools/bench uim342
add_executable(bench_uim342 ${CMAKE_CURRENT_LIST_DIR}/uim342_bench.cpp ${CMAKE_CURRENT_LIST_DIR}/uim342_bench_status.cpp)
target_link_libraries(bench_uim342 PRIVATE motion::warnings motion::uim342_driver motion::sim_uim342 motion::sim_host
  motion::gateway_runtime motion::lcm motion::simbus motion::config motion::lcmtypes Threads::Threads)
set_target_properties(bench_uim342 PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
