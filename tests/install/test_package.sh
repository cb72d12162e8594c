#!/usr/bin/env bash
# ctest debian_package (issues 22, 40): cpack builds the two Debian packages of the installed
# tree. pplvo (runtime): programs, shared data, Python and Java types, depending on shared
# libraries only; pplvo-dev: headers, generated message headers, static libraries, CMake
# package, pkg-config files, .lcm definitions and examples, depending on pplvo (= version) and
# the -dev packages. No file is in both. The runtime package alone, unpacked into a scratch
# root, runs pplvo-synth and pplvo-run; with pplvo-dev beside it the .pc files resolve.
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
arch=$(dpkg --print-architecture)
runtime=$tmp/out/pplvo_${version}_$arch.deb
dev=$tmp/out/pplvo-dev_${version}_$arch.deb
[[ -f $runtime && -f $dev ]] || fail "expected pplvo_ and pplvo-dev_${version}_$arch.deb in: $(ls "$tmp/out")"
echo "packages: $(basename "$runtime") ($(stat -c %s "$runtime") bytes)," \
  "$(basename "$dev") ($(stat -c %s "$dev") bytes)"

# Control fields: field PACKAGE_FILE NAME
field() { dpkg-deb -f "$1" "$2"; }
for deb in "$runtime" "$dev"; do
  dpkg-deb -I "$deb" control
  [[ $(field "$deb" Version) == "$version" ]] || fail "Version of $deb"
  [[ $(field "$deb" Architecture) == "$arch" ]] || fail "Architecture of $deb"
done
[[ $(field "$runtime" Package) == pplvo ]] || fail "runtime Package"
[[ $(field "$dev" Package) == pplvo-dev ]] || fail "dev Package"
# Runtime: shared libraries only (dpkg-shlibdeps), no development package.
depends=$(field "$runtime" Depends)
for dep in 'liblcm1' 'libopencv-core4' 'libyaml-cpp0' 'libc6 ('; do
  [[ $depends == *"$dep"* ]] || fail "pplvo Depends lacks $dep"
done
if [[ $depends == *-dev* ]]; then fail "pplvo depends on a development package: $depends"; fi
for rec in liblcm-java libjchart2d-java default-jre python3; do
  [[ $(field "$runtime" Recommends) == *"$rec"* ]] || fail "pplvo Recommends lacks $rec"
done
# Development: the runtime of the same version and the headers' -dev packages.
depends=$(field "$dev" Depends)
for dep in "pplvo (= $version)" 'liblcm-dev (>= 1.3)' libeigen3-dev libopencv-dev \
  libopencv-contrib-dev libceres-dev libyaml-cpp-dev zlib1g-dev libdeflate-dev; do
  [[ $depends == *"$dep"* ]] || fail "pplvo-dev Depends lacks $dep"
done

contents() { dpkg-deb -c "$1" | awk '{ print $6 }'; }
contents "$runtime" > "$tmp/runtime.contents"
contents "$dev" > "$tmp/dev.contents"
for f in ./usr/bin/pplvo-run ./usr/bin/pplvo-synth ./usr/bin/pplvo-frontend ./usr/bin/pplvo-spy \
  ./usr/bin/pplvo-launch ./usr/share/pplvo/pplvo.yaml ./usr/share/pplvo/cameras/tum_fr1.yaml \
  ./usr/lib/python3/dist-packages/pplvo_msgs/pose_t.py ./usr/share/java/pplvo_msgs.jar; do
  grep -qx "$f" "$tmp/runtime.contents" || fail "$f is not in pplvo"
done
for f in ./usr/include/pplvo_msgs/pose_t.hpp ./usr/include/pplvo/core/trajectory.h \
  ./usr/lib/libpplvo_core.a ./usr/lib/cmake/pplvo/pplvoConfig.cmake \
  ./usr/lib/pkgconfig/pplvo.pc ./usr/lib/pkgconfig/pplvo-msgs.pc \
  ./usr/share/pplvo/lcmtypes/pose_t.lcm ./usr/share/pplvo/examples/cpp/pose_listener.cpp; do
  grep -qx "$f" "$tmp/dev.contents" || fail "$f is not in pplvo-dev"
done
if grep -E '^\./usr/(include|lib/cmake|lib/pkgconfig)/|\.a$' "$tmp/runtime.contents"; then
  fail "development files in the runtime package"
fi
if grep -E '^\./usr/bin/.' "$tmp/dev.contents"; then fail "programs in pplvo-dev"; fi
# Each file in exactly one package (dpkg refuses to install two packages owning one file).
if comm -12 <(grep -v '/$' "$tmp/runtime.contents" | sort) \
  <(grep -v '/$' "$tmp/dev.contents" | sort) | grep .; then
  fail "files in both packages"
fi
if grep -hE '/(test_|bench_)[^/]*$' "$tmp/runtime.contents" "$tmp/dev.contents"; then
  fail "tests or benchmarks packaged"
fi

# apt would install the runtime package on this machine without any development package
# (a dry run: nothing is installed).
if command -v apt-get > /dev/null; then
  apt-get install -s "$runtime" > "$tmp/apt.log" 2>&1 || { cat "$tmp/apt.log" >&2; fail "apt-get -s"; }
  if grep -E '^Inst [^ ]*-dev ' "$tmp/apt.log"; then fail "installing pplvo pulls -dev packages"; fi
fi

# The runtime package alone, unpacked into a scratch root (not installed on this system): its
# programs run and find their shared data.
dpkg-deb -x "$runtime" "$tmp/root"
"$tmp/root/usr/bin/pplvo-synth" --output "$tmp/seq" --frames 2 --width 160 --height 120 \
  > /dev/null || fail "the packaged pplvo-synth does not run"
"$tmp/root/usr/bin/pplvo-run" --dataset "$tmp/seq" --output "$tmp/traj.txt" --quiet \
  > /dev/null || fail "the packaged pplvo-run does not run"
[[ -s $tmp/traj.txt ]] || fail "the packaged pplvo-run wrote no trajectory"
# With the development package beside it: the .pc files resolve in the scratch root.
dpkg-deb -x "$dev" "$tmp/root"
[[ $(PKG_CONFIG_PATH=$tmp/root/usr/lib/pkgconfig pkg-config --cflags pplvo-msgs) == \
  *"$tmp/root/usr/lib/pkgconfig/../../include"* ]] || fail "pplvo-msgs.pc is not relocatable"
echo "PASS"
