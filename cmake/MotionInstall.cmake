# What `cmake --install` gives a program that uses the C++ client (component dev; the motion-*
# programs install with the default component):
#   include/motion/{core,lcm,security,client}/*.hpp, include/motionlcm/*.hpp (lcm-gen's C++ types)
#   lib/libmotion_{client,security,lcm,core}.a
#   lib/cmake/motion/  motionConfig.cmake: find_package(motion) -> motion::client (and motion::security, motion::lcm,
#                      motion::core, motion::lcmtypes)
#   lib/pkgconfig/motion-client.pc
# Both are relocatable: `cmake --install build --prefix DIR` anywhere works.
include(CMakePackageConfigHelpers)

set(MOTION_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/motion)
install(EXPORT motionTargets NAMESPACE motion:: DESTINATION ${MOTION_CMAKE_DIR} COMPONENT dev)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/motionConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/motionConfig.cmake INSTALL_DESTINATION ${MOTION_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/motionConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/motionConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/motionConfigVersion.cmake
  DESTINATION ${MOTION_CMAKE_DIR} COMPONENT dev)

# motion-client.pc: the prefix is found from the file's own place (${pcfiledir}).
get_property(motion_pc_libraries GLOBAL PROPERTY MOTION_INSTALLED_LIBRARIES)
list(REVERSE motion_pc_libraries)
list(TRANSFORM motion_pc_libraries PREPEND "-l")
list(JOIN motion_pc_libraries " " MOTION_PC_LIBS)
file(RELATIVE_PATH MOTION_PC_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
string(REGEX REPLACE "/$" "" MOTION_PC_PREFIX "${MOTION_PC_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/motion-client.pc.in ${CMAKE_CURRENT_BINARY_DIR}/motion-client.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/motion-client.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)
