# CANopen benchmark (included by tools/benchmarks/CMakeLists.txt with MOTION_BUILD_BENCH): SDO
# expedited round trip and segmented throughput, SYNC producer jitter, and UC57 boot-and-configure
# time for 1/8/32 nodes, UC57 status polling (TPDOs every SYNC / staggered), on the bit-timed simulated bus, each against the wire-time bound of the
# same frames. A plain main printing one table (see the header of canopen_bench.cpp).
add_executable(bench_canopen ${CMAKE_CURRENT_LIST_DIR}/canopen_bench.cpp ${CMAKE_CURRENT_LIST_DIR}/canopen_poll_bench.cpp)
target_link_libraries(bench_canopen PRIVATE motion::warnings motion::canopen motion::simbus motion::sim_uc57
  motion::uc57_driver motion::config Threads::Threads)
# Part 4's simulated-clock rig is the one of the UC57 polling tests.
target_include_directories(bench_canopen PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/uc57_driver)
set_target_properties(bench_canopen PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
