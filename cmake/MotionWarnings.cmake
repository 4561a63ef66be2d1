include(GNUInstallDirs)

# Project-wide compile options, applied through an INTERFACE target so that only our own
# targets get them (generated LCM code and third-party headers are built without -Werror).
add_library(motion_warnings INTERFACE)
add_library(motion::warnings ALIAS motion_warnings)
target_compile_options(motion_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion -Wnon-virtual-dtor
  -Wold-style-cast -Woverloaded-virtual -Wimplicit-fallthrough)
if(MOTION_WERROR)
  target_compile_options(motion_warnings INTERFACE -Werror)
endif()
# GCC 12 at -O3 (the Release tree of tools/bench) reports a false -Wrestrict inside libstdc++ for
# `"literal" + std::string` (GCC bug 105651, fixed in GCC 13), which -Werror turned into a failed
# build of most benchmarks. Only that warning, only on GCC 12, only in Release (the other trees
# build clean with it).
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12
   AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(motion_warnings INTERFACE $<$<CONFIG:Release>:-Wno-restrict>)
endif()

if(MOTION_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
endif()

# motion_library(NAME <short> SOURCES ... DEPS ... [PRIVATE_DEPS ...] [INSTALL])
#   -> target motion_<short>, alias motion::<short>
# INSTALL: `cmake --install` (component dev) installs the library and its include/ tree, and the
# exported CMake package (cmake/MotionInstall.cmake) has it as motion::<short>; its DEPS must be
# installed too, or found by motionConfig.cmake.
function(motion_library)
  cmake_parse_arguments(ARG "INSTALL" "NAME" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(target motion_${ARG_NAME})
  set(include_dir $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  if(ARG_SOURCES)
    add_library(${target} STATIC ${ARG_SOURCES})
    target_include_directories(${target} PUBLIC ${include_dir})
    # Warnings are for our own build only: not part of the installed targets' interface.
    target_link_libraries(${target} PUBLIC ${ARG_DEPS} PRIVATE $<BUILD_INTERFACE:motion::warnings> ${ARG_PRIVATE_DEPS})
    set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  else()
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE ${include_dir})
    target_link_libraries(${target} INTERFACE ${ARG_DEPS})
  endif()
  add_library(motion::${ARG_NAME} ALIAS ${target})
  if(ARG_INSTALL)
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${ARG_NAME})
    install(TARGETS ${target} EXPORT motionTargets COMPONENT dev
      ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev
      FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
    if(ARG_SOURCES)
      target_compile_features(${target} PUBLIC cxx_std_20)  # consumers compile our headers as C++20
      # For motion-client.pc's Libs, which lists them in reverse: a library before the ones it
      # depends on (declared earlier).
      set_property(GLOBAL APPEND PROPERTY MOTION_INSTALLED_LIBRARIES ${target})
    else()
      target_compile_features(${target} INTERFACE cxx_std_20)
    endif()
  endif()
endfunction()

# motion_executable(NAME <exe> SOURCES ... DEPS ...)
function(motion_executable)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE motion::warnings ${ARG_DEPS})
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
  install(TARGETS ${ARG_NAME} RUNTIME DESTINATION bin)
endfunction()

# motion_test(NAME <test> SOURCES ... DEPS ... [DEFINITIONS ...] [LABELS ...] [TIMEOUT s])
# A test labelled "unit" (the default) is not created when MOTION_UNIT_TESTS is OFF, so a test's
# own settings go through these arguments, not through target_* calls after it.
# One gtest executable, registered as one ctest entry (gtest_discover_tests would multiply the
# per-test process start-up cost on this 2-core machine).
function(motion_test)
  cmake_parse_arguments(ARG "" "NAME;TIMEOUT" "SOURCES;DEPS;DEFINITIONS;LABELS" ${ARGN})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if("unit" IN_LIST ARG_LABELS AND NOT MOTION_UNIT_TESTS)
    return()
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE motion::warnings ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  if(ARG_DEFINITIONS)
    target_compile_definitions(${ARG_NAME} PRIVATE ${ARG_DEFINITIONS})
  endif()
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  add_test(NAME ${ARG_NAME} COMMAND ${ARG_NAME} --gtest_color=no)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  if("unit" IN_LIST ARG_LABELS)
    set_property(GLOBAL APPEND PROPERTY MOTION_UNIT_TESTS ${ARG_NAME})
  endif()
  set_tests_properties(${ARG_NAME} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    ENVIRONMENT "MOTION_BIN_DIR=${CMAKE_BINARY_DIR}/bin;MOTION_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
endfunction()
