# The installed layout (GNUInstallDirs): cmake --install build [--prefix P],
# or the Debian package CPack makes of it (cd build && cpack; ./holofuse
# package). The shaders are compiled into the programs as SPIR-V
# (shaders/CMakeLists.txt), so nothing is looked up at run time; the loop
# launcher starts the programs installed beside it.
include(GNUInstallDirs)
install(TARGETS ${HOLOFUSE_PROGRAMS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES README.md SECURITY.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES deploy/rig.yaml DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)
install(DIRECTORY deploy/k8s DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)
# systemd's search path holds PREFIX/lib/systemd/system for /usr and
# /usr/local alike.
install(CODE "
  set(HOLOFUSE_UNITS_SOURCE \"${PROJECT_SOURCE_DIR}/deploy/systemd\")
  set(HOLOFUSE_UNITS holofuse-server.service holofuse-pod@.service holofuse-client@.service)
  set(HOLOFUSE_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
  set(HOLOFUSE_DOCDIR \"${CMAKE_INSTALL_DOCDIR}\")
  set(HOLOFUSE_UNITDIR lib/systemd/system)")
install(SCRIPT cmake/InstallUnits.cmake)

# A Debian package of the same files, its dependencies read off the
# programs' libraries by dpkg-shlibdeps (dpkg-dev).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME holofuse)
set(CPACK_PACKAGE_VENDOR "holofuse")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "live free-viewpoint telepresence: camera pods, a visual-hull fusion server, render clients")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "holofuse developers")
set(CPACK_DEBIAN_PACKAGE_SECTION video)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# lavapipe, the Vulkan device of a host without a GPU driver.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS mesa-vulkan-drivers)
set(CPACK_STRIP_FILES ON)
include(CPack)
