# End-to-end benchmark on the simulated lab (included by tools/benchmarks/CMakeLists.txt with
# MOTION_BUILD_BENCH): starts motion-sim, the gateways and the coordinator on its own LCM URL and
# simulation directory, measures client request -> STARTED latency and start skews against raw LCM
# round trips and CAN wire time measured in the same run, and kills the processes at the end.
add_executable(bench_e2e ${CMAKE_CURRENT_LIST_DIR}/e2e_bench.cpp)
target_link_libraries(bench_e2e PRIVATE motion::warnings motion::client motion::config motion::simbus motion::canopen motion::lcmtypes Threads::Threads)
target_compile_definitions(bench_e2e PRIVATE
  MOTION_E2E_BIN_DIR="$<TARGET_FILE_DIR:motion-coordinator>"
  MOTION_E2E_CONFIG="${CMAKE_SOURCE_DIR}/config/sim-lab.yaml")
add_dependencies(bench_e2e motion-sim motion-gateway motion-coordinator)
set_target_properties(bench_e2e PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
