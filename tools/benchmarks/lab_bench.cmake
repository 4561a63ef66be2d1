# Lab-scale benchmark (included by tools/benchmarks/CMakeLists.txt with MOTION_BUILD_BENCH): a
# generated configuration of eight simulated buses and about 360 drives, every process on one host,
# on its own LCM URL and simulation directory; CPU and RSS per process, status updates and bus load
# per bus, request latency and start skew against bounds of the same run. `tools/bench lab`.
add_executable(bench_lab ${CMAKE_CURRENT_LIST_DIR}/lab_bench.cpp)
target_link_libraries(bench_lab PRIVATE motion::warnings motion::client motion::config motion::lcmtypes motion::adam Threads::Threads)
target_compile_definitions(bench_lab PRIVATE MOTION_LAB_BIN_DIR="$<TARGET_FILE_DIR:motion-coordinator>")
add_dependencies(bench_lab motion-sim motion-gateway motion-coordinator)
set_target_properties(bench_lab PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
