# Packaging (issue 6): one Debian package, `mfns`, with the flyer's software:
#   /usr/bin/mfns-navd (when the target exists), /usr/bin/mfns-paramctl,
#   /usr/lib/systemd/system/mfns-navd.service, /etc/mfns/navd.conf (conffile, EnvironmentFile),
#   /var/lib/mfns/params (the parameter store).
# `cmake --build --preset aarch64 --target package` gives mfns_<version>_arm64.deb; the host
# presets give the same package for the build machine's architecture. Only the install
# component "flyer" is packaged (other install rules in the tree stay out of the .deb).
# Included from the top-level CMakeLists.txt after add_subdirectory(firmware).

# Whether mfns-navd sends sd_notify READY=1 / WATCHDOG=1: the unit is then Type=notify with a
# watchdog; otherwise Type=simple (restart on failure only).
option(MFNS_NAVD_SD_NOTIFY "mfns-navd sends sd_notify READY=1 and WATCHDOG=1 (unit Type=notify, WatchdogSec)" ON)
if(MFNS_NAVD_SD_NOTIFY)
  set(MFNS_UNIT_TYPE notify)
  set(MFNS_UNIT_WATCHDOG "NotifyAccess=main\nWatchdogSec=5s")
else()
  set(MFNS_UNIT_TYPE simple)
  set(MFNS_UNIT_WATCHDOG "# No WatchdogSec: this build of mfns-navd does not send sd_notify (MFNS_NAVD_SD_NOTIFY=OFF).")
endif()
set(_mfns_pkg_src ${CMAKE_CURRENT_LIST_DIR})
set(_mfns_pkg_bin ${CMAKE_BINARY_DIR}/packaging)
configure_file(${_mfns_pkg_src}/mfns-navd.service.in ${_mfns_pkg_bin}/mfns-navd.service @ONLY)
file(MAKE_DIRECTORY ${_mfns_pkg_bin}/empty)

set(_mfns_pkg_binaries mfns-paramctl)
if(TARGET mfns-navd)
  list(APPEND _mfns_pkg_binaries mfns-navd)
endif()
install(TARGETS ${_mfns_pkg_binaries} RUNTIME DESTINATION bin COMPONENT flyer)
install(FILES ${_mfns_pkg_bin}/mfns-navd.service DESTINATION lib/systemd/system COMPONENT flyer)
install(FILES ${_mfns_pkg_src}/navd.conf DESTINATION /etc/mfns COMPONENT flyer)
install(DIRECTORY ${_mfns_pkg_bin}/empty/ DESTINATION /var/lib/mfns/params COMPONENT flyer)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME mfns)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "MFNS maintainers <mfns@example.invalid>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "MFNS multi-camera LED-beacon navigation: mfns-navd, mfns-paramctl")
set(CPACK_PACKAGE_DESCRIPTION "Navigation daemon (systemd unit mfns-navd) and parameter store tool for a free-flying robot.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_CMAKE_PROJECTS "${CMAKE_BINARY_DIR};${PROJECT_NAME};flyer;/")
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
# Not dpkg-shlibdeps: it cannot resolve the cross toolchain's arm64 libstdc++. Bookworm's versions.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libc6 (>= 2.36), libstdc++6 (>= 12), libgpiod2 (>= 1.6)")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    "${_mfns_pkg_src}/debian/conffiles;${_mfns_pkg_src}/debian/postinst;${_mfns_pkg_src}/debian/prerm;${_mfns_pkg_src}/debian/postrm")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
if(CMAKE_CROSSCOMPILING)
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
    set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
  else()
    message(FATAL_ERROR "Packaging: no Debian architecture known for ${CMAKE_SYSTEM_PROCESSOR}")
  endif()
endif()
include(CPack)

# Test: build the package into its own directory (fixture), then inspect it with dpkg-deb.
find_program(MFNS_DPKG_DEB dpkg-deb)
if(MFNS_DPKG_DEB)
  if(CMAKE_CROSSCOMPILING)
    set(_mfns_pkg_arch arm64)
    set(_mfns_pkg_machine 183)  # ELF e_machine EM_AARCH64
    set(_mfns_pkg_labels "firmware;package")
  else()
    execute_process(COMMAND dpkg --print-architecture OUTPUT_VARIABLE _mfns_pkg_arch OUTPUT_STRIP_TRAILING_WHITESPACE)
    set(_mfns_pkg_machine "")
    if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
      set(_mfns_pkg_machine 62)  # EM_X86_64
    elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
      set(_mfns_pkg_machine 183)
    endif()
    set(_mfns_pkg_labels "host;package")
  endif()
  set(_mfns_pkg_out ${CMAKE_BINARY_DIR}/package-test)
  string(REPLACE ";" "," _mfns_pkg_binaries_csv "${_mfns_pkg_binaries}")
  add_test(NAME package_build
           COMMAND ${CMAKE_COMMAND} -DCPACK=${CMAKE_CPACK_COMMAND} -DCONFIG=${CMAKE_BINARY_DIR}/CPackConfig.cmake
                   -DOUT=${_mfns_pkg_out} -P ${_mfns_pkg_src}/build_package.cmake)
  set_tests_properties(package_build PROPERTIES FIXTURES_SETUP mfns_package LABELS "${_mfns_pkg_labels}" TIMEOUT 300)
  add_test(NAME package_contents
           COMMAND ${CMAKE_COMMAND} -DDPKG_DEB=${MFNS_DPKG_DEB} -DDIR=${_mfns_pkg_out}
                   -DNAME=${CPACK_PACKAGE_NAME} -DVERSION=${PROJECT_VERSION} -DARCH=${_mfns_pkg_arch}
                   -DMACHINE=${_mfns_pkg_machine} "-DBINARIES=${_mfns_pkg_binaries_csv}" -DSD_NOTIFY=${MFNS_NAVD_SD_NOTIFY}
                   -P ${_mfns_pkg_src}/check_package.cmake)
  set_tests_properties(package_contents PROPERTIES FIXTURES_REQUIRED mfns_package LABELS "${_mfns_pkg_labels}"
                       TIMEOUT 120)
endif()
