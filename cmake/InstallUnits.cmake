# Run by cmake --install and by CPack: writes the systemd unit templates
# (deploy/systemd/*.service.in) with the installed programs' and docs'
# folders in. Here CMAKE_INSTALL_PREFIX is the install's own (--prefix, or
# CPack's /usr), not the configure's, so a unit always names the programs
# that were installed beside it.
# The markers are @NAME@: under the old policies an install script starts
# with, CMake would read them as variable references.
cmake_policy(PUSH)
cmake_policy(VERSION 3.25)
foreach(unit IN LISTS HOLOFUSE_UNITS)
  file(READ "${HOLOFUSE_UNITS_SOURCE}/${unit}.in" text)
  string(REPLACE "@HOLOFUSE_BINDIR@" "${CMAKE_INSTALL_PREFIX}/${HOLOFUSE_BINDIR}" text "${text}")
  string(REPLACE "@HOLOFUSE_DOCDIR@" "${CMAKE_INSTALL_PREFIX}/${HOLOFUSE_DOCDIR}" text "${text}")
  set(installed "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${HOLOFUSE_UNITDIR}/${unit}")
  message(STATUS "Installing: ${installed}")
  file(WRITE "${installed}" "${text}")
  list(APPEND CMAKE_INSTALL_MANIFEST_FILES "${installed}")
endforeach()
cmake_policy(POP)
