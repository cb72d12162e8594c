# Debian package of the installed tree (issue 22): `cpack --config build/CPackConfig.cmake`
# writes pplvo_<version>_<arch>.deb (prefix /usr) so that a robot installs pplvo with apt.
# Depends: the shared libraries the programs link (found by dpkg-shlibdeps, from dpkg-dev,
# which build-essential brings) and the -dev packages the installed headers, static libraries
# and CMake package need; Recommends: what lcm-spy (pplvo-spy), lcm-gen and the Python
# example use. Checked by the ctest debian_package (tests/install/test_package.sh).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME pplvo)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "probabilistic RGB-D visual odometry (points, lines, planes) as LCM processes and libraries")
set(CPACK_PACKAGE_DESCRIPTION
    "pplvo estimates the camera motion of an RGB-D sensor from points, line segments and planes \
under depth uncertainty (Proenca & Gao, RAS 2018). The package holds the LCM processes \
(pplvo-player, pplvo-depth-filter, pplvo-frontend, pplvo-estimator, pplvo-run, ...), the \
libraries with their headers, CMake package and pkg-config files, the LCM message types for C++, \
Python and Java, and pplvo-spy.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "pplvo developers <pplvo@localhost>")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS
    "liblcm-dev (>= 1.3), libeigen3-dev, libopencv-dev, libopencv-contrib-dev, libceres-dev, \
libyaml-cpp-dev, zlib1g-dev, libdeflate-dev, libturbojpeg0-dev")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS
    "liblcm-bin, liblcm-java, libjchart2d-java, default-jre, python3, pkg-config")
include(CPack)
