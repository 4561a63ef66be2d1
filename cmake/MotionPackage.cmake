# What `cmake --install` gives a lab machine besides the C++ client (cmake/MotionInstall.cmake),
# and the .deb (`tools/package`: cpack -G DEB). Paths below are relative to the prefix unless said:
#   bin/                         motion-gateway, motion-coordinator, motion-sim, motion-web, motionctl
#   share/motion/web/            the web view's page and Chart.js (services/web)
#   share/motionbus/lcmtypes/    the LCM type definitions (*.lcm), for lcm-gen in other languages
#   share/java/motionlcm.jar     generated Java types (lcm-spy, Java clients), when javac was found
#   lib/python3*/dist-packages/motionlcm/, share/lua/5.2/motionlcm/   generated Python and Lua types
#   share/motionbus/config/      sim-lab.yaml (the default configuration), examples/hardware.yaml,
#                                motion.env
#   etc/motionbus/               lab.yaml (the hardware example) and motion.env, what the units read;
#                                /etc/motionbus for the prefix /usr (the .deb: conffiles)
#   lib/systemd/system/          motion-gateway@.service, motion-coordinator.service,
#                                motion-web.service, motion-sim.service, motionbus.target, with
#                                ExecStart= and the /etc paths of this prefix
#   lib/sysusers.d/motionbus.conf   the motionbus system user
#   share/bash-completion/completions/motionctl
#   share/doc/motionbus/         README.md, LICENSE
include(GNUInstallDirs)

# LCM types: definitions and the generated bindings of the languages without a build step.
install(FILES ${MOTION_LCM_TYPES} DESTINATION ${CMAKE_INSTALL_DATADIR}/motionbus/lcmtypes)
if(MOTION_LCM_JAR)
  install(FILES ${MOTION_LCM_JAR} DESTINATION ${CMAKE_INSTALL_DATADIR}/java)
endif()
install(DIRECTORY ${CMAKE_BINARY_DIR}/lcmtypes/lua/motionlcm DESTINATION ${CMAKE_INSTALL_DATADIR}/lua/5.2
  FILES_MATCHING PATTERN "*.lua")

# Configurations.
install(FILES ${PROJECT_SOURCE_DIR}/config/sim-lab.yaml ${PROJECT_SOURCE_DIR}/config/systemd/motion.env
  DESTINATION ${CMAKE_INSTALL_DATADIR}/motionbus/config)
install(FILES ${PROJECT_SOURCE_DIR}/config/examples/hardware.yaml DESTINATION ${CMAKE_INSTALL_DATADIR}/motionbus/config/examples)
# etc/motionbus, systemd units and Python types: their places depend on the prefix installed to.
execute_process(COMMAND ${MOTION_PYTHON3} -c "import sys; print('%d.%d' % sys.version_info[:2])"
  OUTPUT_VARIABLE motion_python_version OUTPUT_STRIP_TRAILING_WHITESPACE)
install(CODE "
  set(MOTION_SOURCE_DIR \"${PROJECT_SOURCE_DIR}\")
  set(MOTION_BINARY_DIR \"${CMAKE_BINARY_DIR}\")
  set(MOTION_PYTHON_VERSION \"${motion_python_version}\")
  include(\"${CMAKE_CURRENT_LIST_DIR}/MotionInstallSystem.cmake\")")
install(FILES ${PROJECT_SOURCE_DIR}/config/systemd/motionbus.sysusers DESTINATION lib/sysusers.d RENAME motionbus.conf)

install(FILES ${PROJECT_SOURCE_DIR}/tools/motionctl/motionctl.bash-completion
  DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions RENAME motionctl)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})

# --- cpack -G DEB (tools/package): the same build tree, installed to /usr ----------------------
set(CPACK_PACKAGE_NAME motionbus)
set(CPACK_PACKAGE_VENDOR "motionbus")
set(CPACK_PACKAGE_CONTACT "motionbus maintainers <motionbus@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_RESOURCE_FILE_README ${PROJECT_SOURCE_DIR}/README.md)
# Installed with CMAKE_INSTALL_PREFIX=/usr under DESTDIR=<staging>, so /etc/motionbus (an absolute
# destination of cmake/MotionInstallSystem.cmake) lands in the package and not on this machine.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)  # the build's -g1 debug information stays out of the package
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # dpkg-shlibdeps: liblcm1, libyaml-cpp, libsodium, libsystemd0, ...
# Not found by dpkg-shlibdeps: sysusers and systemctl in the maintainer scripts.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "systemd")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "liblcm-bin, liblcm-java, can-utils")
set(motion_deb_dir ${CMAKE_BINARY_DIR}/deb)
configure_file(${PROJECT_SOURCE_DIR}/tools/lib/deb/postinst ${motion_deb_dir}/postinst COPYONLY)
configure_file(${PROJECT_SOURCE_DIR}/tools/lib/deb/postrm ${motion_deb_dir}/postrm COPYONLY)
file(WRITE ${motion_deb_dir}/conffiles "/etc/motionbus/lab.yaml\n/etc/motionbus/motion.env\n")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${motion_deb_dir}/postinst ${motion_deb_dir}/postrm ${motion_deb_dir}/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
