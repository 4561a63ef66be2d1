# Cost of signed requests: a client signing one, the coordinator's verifier checking it; a gateway's
# signed AXIS_STATE against an unsigned LCM round trip.
add_executable(bench_security ${CMAKE_CURRENT_LIST_DIR}/security_bench.cpp)
target_link_libraries(bench_security PRIVATE motion::warnings benchmark::benchmark motion::security motion::lcmtypes PkgConfig::LCM)
set_target_properties(bench_security PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
