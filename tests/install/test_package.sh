#!/usr/bin/env bash
# ctest debian_package (issue 22): cpack builds the Debian package of the installed tree; its
# control file names the package, version, architecture and the Debian dependencies (shared
# libraries found by dpkg-shlibdeps and the -dev packages of the headers), its contents hold
# the programs, headers, generated message headers, libraries, CMake package, pkg-config files,
# Java jar and Python package under /usr; unpacked into a scratch root, the installed
# pplvo-synth runs and pkg-config resolves the relocatable .pc files.
# Usage: test_package.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_package_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$build/CMakeCache.txt")
[[ -n $version ]] || fail "no project version in $build/CMakeCache.txt"
(cd "$tmp" && cpack --config "$build/CPackConfig.cmake" -B "$tmp/out" > "$tmp/cpack.log") ||
  { cat "$tmp/cpack.log" >&2; fail "cpack"; }
deb=$(find "$tmp/out" -maxdepth 1 -name "pplvo_${version}_*.deb")
[[ -f $deb ]] || fail "no pplvo_${version}_*.deb in $(ls "$tmp/out")"
echo "package: $(basename "$deb")"

dpkg-deb -I "$deb" control > "$tmp/control"
cat "$tmp/control"
field() { sed -n "s/^$1: //p" "$tmp/control"; }
[[ $(field Package) == pplvo ]] || fail "Package"
[[ $(field Version) == "$version" ]] || fail "Version"
[[ $(field Architecture) == "$(dpkg --print-architecture)" ]] || fail "Architecture"
depends=$(field Depends)
for dep in 'liblcm1' 'libopencv-core4' 'libyaml-cpp0' 'libc6 (' 'liblcm-dev (>= 1.3)' \
  libeigen3-dev libopencv-dev libopencv-contrib-dev libceres-dev libyaml-cpp-dev zlib1g-dev \
  libdeflate-dev; do
  [[ $depends == *"$dep"* ]] || fail "Depends lacks $dep"
done
for rec in liblcm-java libjchart2d-java default-jre python3; do
  [[ $(field Recommends) == *"$rec"* ]] || fail "Recommends lacks $rec"
done

dpkg-deb -c "$deb" | awk '{ print $6 }' > "$tmp/contents"
for f in ./usr/bin/pplvo-run ./usr/bin/pplvo-synth ./usr/bin/pplvo-frontend ./usr/bin/pplvo-spy \
  ./usr/include/pplvo_msgs/pose_t.hpp ./usr/include/pplvo/core/trajectory.h \
  ./usr/lib/libpplvo_core.a ./usr/lib/cmake/pplvo/pplvoConfig.cmake \
  ./usr/lib/pkgconfig/pplvo.pc ./usr/lib/pkgconfig/pplvo-msgs.pc \
  ./usr/lib/python3/dist-packages/pplvo_msgs/pose_t.py ./usr/share/java/pplvo_msgs.jar \
  ./usr/share/pplvo/examples/cpp/pose_listener.cpp; do
  grep -qx "$f" "$tmp/contents" || fail "$f is not in the package"
done
if grep -E '/(test_|bench_)[^/]*$' "$tmp/contents"; then fail "tests or benchmarks packaged"; fi

# Unpacked into a scratch root (not installed on this system): programs run, .pc files resolve.
dpkg-deb -x "$deb" "$tmp/root"
"$tmp/root/usr/bin/pplvo-synth" --output "$tmp/seq" --frames 2 --width 160 --height 120 \
  > /dev/null || fail "the packaged pplvo-synth does not run"
[[ $(PKG_CONFIG_PATH=$tmp/root/usr/lib/pkgconfig pkg-config --cflags pplvo-msgs) == \
  *"$tmp/root/usr/lib/pkgconfig/../../include"* ]] || fail "pplvo-msgs.pc is not relocatable"
echo "PASS"
