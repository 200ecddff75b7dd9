# The Debian package (cpack -G DEB; deploy/package builds and runs it): mocapd_<version>_<arch>.deb
# holding everything the install rules place under /usr, and /etc/mocapd/mocapd.yaml as a conffile.
# Included by the top-level CMakeLists.txt when the install prefix is /usr.
include(GNUInstallDirs)

set(MOCAP_DEB_MAINTAINER "mocapd maintainers <maintainers@mocapd.invalid>" CACHE STRING
    "The Debian package's Maintainer field and changelog signature")

# A native package's documentation: the copyright file and the changelog, compressed as Debian
# requires (gzip -9n: no name or time stamp, so the package is reproducible).
set(deb_doc_dir ${CMAKE_INSTALL_DATADIR}/doc/mocapd)
configure_file(${CMAKE_CURRENT_LIST_DIR}/changelog.in ${CMAKE_BINARY_DIR}/debian/changelog @ONLY)
install(CODE "execute_process(COMMAND gzip -9n -f -k \"${CMAKE_BINARY_DIR}/debian/changelog\"
                              COMMAND_ERROR_IS_FATAL ANY)")
install(FILES ${CMAKE_BINARY_DIR}/debian/changelog.gz ${CMAKE_CURRENT_LIST_DIR}/copyright
        DESTINATION ${deb_doc_dir})

# A program's manual page, made from its --help at install time (deploy/debian/manpage.cmake).
function(mocap_install_manpage program summary)
  set(page ${CMAKE_BINARY_DIR}/debian/${program}.1)
  install(CODE "execute_process(COMMAND \"${CMAKE_COMMAND}\" -DPROGRAM=$<TARGET_FILE:${program}>
                  -DNAME=${program} \"-DSUMMARY=${summary}\" -DVERSION=${PROJECT_VERSION}
                  -DOUT=${page} -P ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/manpage.cmake
                  COMMAND_ERROR_IS_FATAL ANY)")
  install(FILES ${page}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
endfunction()
mocap_install_manpage(mocapd "live markerless motion-capture daemon")
mocap_install_manpage(mocapctl "command-line client of mocapd")

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME mocapd)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT ${MOCAP_DEB_MAINTAINER})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "live markerless motion-capture daemon")
# The long description (the summary above is its first line): under 80 columns, as Debian's
# tools show it unwrapped.
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION [[
mocapd groups the frames of two or more cameras (V4L2, GigE and USB3 Vision
through Aravis, libcamera) by time, turns them into silhouettes, tracks an
articulated body with a factored particle filter and streams the poses over
gRPC. Sessions can be recorded and replayed.
.
This package holds the daemon, its command-line client mocapctl, a systemd
unit, the udev rule for camera access, the body models, example
configurations and the Python client module.]])
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION video)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# Library dependencies come from the binaries (dpkg-shlibdeps). systemd-sysusers creates the user
# in postinst. The Python client's modules and the web view's three.js are not seen by shlibdeps
# and the daemon runs without them: recommended, not required.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd | systemd-sysusers")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3, python3-grpcio, python3-protobuf, python3-numpy, libjs-three")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${CMAKE_CURRENT_LIST_DIR}/conffiles
    ${CMAKE_CURRENT_LIST_DIR}/postinst ${CMAKE_CURRENT_LIST_DIR}/prerm ${CMAKE_CURRENT_LIST_DIR}/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_STRIP_FILES ON)
# Install with DESTDIR, so the install rules see the real prefix (/usr): the unit's ExecStart is
# rewritten to /usr/bin/mocapd, and /etc/mocapd lands in the package, not on the build machine.
set(CPACK_SET_DESTDIR ON)
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
include(CPack)
