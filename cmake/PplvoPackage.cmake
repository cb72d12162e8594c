# Debian packages of the installed tree (issues 22, 40): `cpack --config build/CPackConfig.cmake`
# writes two packages (prefix /usr), one per install component (PplvoInstall.cmake):
#   pplvo_<version>_<arch>.deb      runtime: the programs, pplvo-spy, the default configuration
#                                   and camera files, the Python and Java message types. Depends
#                                   only on the shared libraries the programs link (found by
#                                   dpkg-shlibdeps): a robot gets no compiler headers.
#   pplvo-dev_<version>_<arch>.deb  development: headers, static libraries, CMake package,
#                                   pkg-config files, .lcm definitions, examples. Depends on
#                                   pplvo (= version) and the -dev packages its headers and
#                                   static libraries need.
# Recommends: what lcm-spy (pplvo-spy) and the Python types use; lcm-gen for the definitions.
# Checked by the ctest debian_package (tests/install/test_package.sh).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME pplvo)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "pplvo developers <pplvo@localhost>")
set(CPACK_DEBIAN_PACKAGE_SECTION science)

set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME pplvo)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS
    "liblcm-bin, liblcm-java, libjchart2d-java, default-jre, python3")
set(CPACK_COMPONENT_RUNTIME_DESCRIPTION
    "probabilistic RGB-D visual odometry (points, lines, planes) as LCM processes
 pplvo estimates the camera motion of an RGB-D sensor from points, line segments and planes
 under depth uncertainty (Proenca & Gao, RAS 2018). This package holds the LCM processes
 (pplvo-player, pplvo-camera, pplvo-depth-filter, pplvo-frontend, pplvo-estimator, pplvo-launch,
 pplvo-run, ...), pplvo-spy, the default configuration and camera files, and the message types
 for Python and Java. Headers and libraries to build against are in pplvo-dev.")

set(CPACK_DEBIAN_DEV_PACKAGE_NAME pplvo-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
    "pplvo (= ${PROJECT_VERSION}), liblcm-dev (>= 1.3), libeigen3-dev, libopencv-dev, \
libopencv-contrib-dev, libceres-dev, libyaml-cpp-dev, zlib1g-dev, libdeflate-dev, \
libturbojpeg0-dev")
set(CPACK_DEBIAN_DEV_PACKAGE_RECOMMENDS "pkg-config, liblcm-bin")
set(CPACK_COMPONENT_DEV_DESCRIPTION
    "probabilistic RGB-D visual odometry: headers, libraries and message definitions
 The headers, static libraries, CMake package (find_package(pplvo)) and pkg-config files
 (pplvo, pplvo-msgs) of pplvo's libraries and LCM message types, the .lcm definitions, and the
 examples (a C++ pose listener, a Python listener, fusion with wheel odometry).")
include(CPack)
