# Install-time part of cmake/MotionPackage.cmake: what depends on the prefix actually installed to
# (`cmake --install --prefix P`, or /usr for cpack), not the one configured:
#   etc/motionbus/{lab.yaml,motion.env}  (motion.env's paths rewritten as the units') /etc/motionbus for the prefix /usr (GNUInstallDirs' rule),
#                                        <prefix>/etc/motionbus otherwise
#   lib/systemd/system/                  the units of config/systemd, /usr/local/ rewritten to
#                                        <prefix>/ and /etc/motionbus to the etc folder above
#   Python types                         lib/python3/dist-packages for /usr (Debian's packaged
#                                        modules), else lib/python3.X/dist-packages
# Input: MOTION_SOURCE_DIR, MOTION_BINARY_DIR, MOTION_PYTHON_VERSION (3.X).
# file(INSTALL) puts everything under $DESTDIR when it is set.
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(motion_etc /etc/motionbus)
  set(motion_python lib/python3/dist-packages)
else()
  set(motion_etc "${CMAKE_INSTALL_PREFIX}/etc/motionbus")
  set(motion_python lib/python${MOTION_PYTHON_VERSION}/dist-packages)
endif()

# One staging folder per destination: installs to several prefixes may run at once.
string(MD5 destination "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}")
set(staging "${MOTION_BINARY_DIR}/systemd/${destination}")
file(MAKE_DIRECTORY "${staging}")
set(staged "")
foreach(name motion-gateway@.service motion-coordinator.service motion-web.service motion-sim.service motionbus.target motion.env)
  file(READ "${MOTION_SOURCE_DIR}/config/systemd/${name}" text)
  string(REPLACE "/usr/local/" "${CMAKE_INSTALL_PREFIX}/" text "${text}")
  string(REPLACE "/etc/motionbus" "${motion_etc}" text "${text}")
  file(WRITE "${staging}/${name}" "${text}")
  list(APPEND staged "${staging}/${name}")
endforeach()
list(REMOVE_ITEM staged "${staging}/motion.env")
file(INSTALL DESTINATION "${CMAKE_INSTALL_PREFIX}/lib/systemd/system" TYPE FILE FILES ${staged})
file(INSTALL DESTINATION "${motion_etc}" TYPE FILE FILES "${staging}/motion.env")
file(INSTALL DESTINATION "${motion_etc}" TYPE FILE RENAME lab.yaml FILES "${MOTION_SOURCE_DIR}/config/examples/hardware.yaml")

file(INSTALL DESTINATION "${CMAKE_INSTALL_PREFIX}/${motion_python}" TYPE DIRECTORY
  FILES "${MOTION_BINARY_DIR}/lcmtypes/python/motionlcm" FILES_MATCHING PATTERN "*.py")
