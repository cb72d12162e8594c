#!/usr/bin/env bash
# ctest install_example_node (issue 22): installs the build into a temporary prefix and uses it
# as another project would, with nothing from the build tree:
#  1. the installed layout (programs, headers, generated message headers, libraries, CMake
#     package, pkg-config files, Java jar, Python package) and no path into the build or
#     source tree in the CMake and pkg-config files;
#  2. the installed pplvo-synth writes a short synthetic sequence, the installed pplvo-run
#     runs it with --log (an LCM event log) and --output (its TUM trajectory);
#  3. examples/cpp (as installed in PREFIX/share/pplvo/examples) is configured with
#     find_package(pplvo) and built; pose_listener reads PPLVO_POSE from the log through the
#     file:// provider and through memq:// and must write pplvo-run's trajectory exactly;
#  4. the same source built with `pkg-config --cflags --libs pplvo` gives the same output, and
#     every installed header compiles with pkg-config's flags (nothing of the source tree);
#  5. the installed Python package and examples/python/pplvo_log_to_tum.py give the same
#     trajectory (within 1e-8) and the same covariances, text for text, as pose_listener.
# Usage: test_install.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_install_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
step() { echo "== $*"; }

step "cmake --install $build --prefix $prefix"
cmake --install "$build" --prefix "$prefix" > "$tmp/install.log"
for f in bin/pplvo-run bin/pplvo-synth bin/pplvo-viewer bin/pplvo-logger bin/pplvo-spy \
  include/pplvo_msgs/pose_t.hpp include/pplvo/core/trajectory.h \
  include/pplvo/msgs/convert_pose.h lib/libpplvo_core.a lib/libpplvo_msgs_util.a \
  lib/cmake/pplvo/pplvoConfig.cmake lib/cmake/pplvo/pplvo-targets.cmake \
  lib/cmake/pplvo/pplvo-msgs-targets.cmake lib/pkgconfig/pplvo.pc lib/pkgconfig/pplvo-msgs.pc \
  share/java/pplvo_msgs.jar lib/python3/dist-packages/pplvo_msgs/pose_t.py \
  share/pplvo/lcmtypes/pose_t.lcm share/pplvo/examples/cpp/CMakeLists.txt \
  share/pplvo/examples/python/pplvo_log_to_tum.py share/pplvo/cameras/tum_fr1.yaml \
  share/pplvo/cameras/kinect_v1.yaml share/pplvo/examples/fusion/CMakeLists.txt; do
  [[ -e $prefix/$f ]] || fail "$f is not installed"
done
if grep -rlF -e "$build" -e "$src" "$prefix/lib/cmake" "$prefix/lib/pkgconfig"; then
  fail "installed package files refer to the build or source tree"
fi

step "installed pplvo-synth and pplvo-run --log"
export LCM_DEFAULT_URL=memq://
"$prefix/bin/pplvo-synth" --output "$tmp/seq" --frames 30 --seed 5 > /dev/null
"$prefix/bin/pplvo-run" --dataset "$tmp/seq" --log "$tmp/run.lcm" --output "$tmp/run.txt" \
  --quiet 2> "$tmp/run.err" || { cat "$tmp/run.err" >&2; fail "pplvo-run"; }
poses=$(grep -vc '^#' "$tmp/run.txt")
[[ $poses -ge 25 ]] || fail "pplvo-run wrote only $poses poses"

step "examples/cpp against the prefix (find_package)"
cmake -S "$prefix/share/pplvo/examples/cpp" -B "$tmp/example" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" > "$tmp/example_configure.log" ||
  { cat "$tmp/example_configure.log" >&2; fail "configure the example"; }
cmake --build "$tmp/example" -j2 > "$tmp/example_build.log" ||
  { cat "$tmp/example_build.log" >&2; fail "build the example"; }
if grep -F -e "$build" -e "$src/" "$tmp/example/CMakeCache.txt" \
  "$tmp/example/CMakeFiles/pose_listener.dir/flags.make" \
  "$tmp/example/CMakeFiles/pose_listener.dir/link.txt"; then
  fail "the example was built with paths into pplvo's build or source tree"
fi

step "examples/fusion against the prefix: messages, conversions and core only"
cmake -S "$prefix/share/pplvo/examples/fusion" -B "$tmp/fusion" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" > "$tmp/fusion_configure.log" ||
  { cat "$tmp/fusion_configure.log" >&2; fail "configure examples/fusion"; }
cmake --build "$tmp/fusion" -j2 > "$tmp/fusion_build.log" ||
  { cat "$tmp/fusion_build.log" >&2; fail "build examples/fusion"; }
# (opencv_core and opencv_imgproc come with the message conversions, pplvo_msgs_util.)
if grep -E 'ceres|opencv_(features2d|calib3d|ximgproc|line_descriptor)|pplvo_(pipeline|tracking|features|estimator|geometry)' \
  "$tmp/fusion/CMakeFiles/fuse_odometry.dir/link.txt"; then
  fail "examples/fusion links more than it uses"
fi

step "pose_listener needs LCM alone at run time (no OpenCV, Ceres, yaml-cpp shared library)"
# ldd's output in a variable: `ldd | grep -q` under pipefail fails when grep exits at its
# first match before ldd has written everything (SIGPIPE; seen on a loaded machine).
libs=$(ldd "$tmp/example/pose_listener")
if grep -E 'opencv|ceres|yaml|glog|cholmod' <<< "$libs"; then
  fail "pose_listener loads libraries it does not use"
fi
grep -q liblcm <<< "$libs" || fail "pose_listener without liblcm?"

step "pose_listener --log (file:// provider)"
"$tmp/example/pose_listener" --log "$tmp/run.lcm" --tum "$tmp/file.txt" \
  --covariance "$tmp/file_cov.txt" > "$tmp/file.out"
head -n 3 "$tmp/file.out"
[[ $(grep -c '^pose ' "$tmp/file.out") -eq $poses ]] || fail "pose_listener printed a wrong count"
grep -q 'sigma rel. t \[mm\]' "$tmp/file.out" || fail "no covariance printed"
cmp "$tmp/run.txt" "$tmp/file.txt" || fail "pose_listener's trajectory differs from pplvo-run's"
# Tracking frames carry a real covariance: positive translation variances.
awk '!/^#/ && NR > 2 { if ($2 > 0 && $9 > 0 && $16 > 0) good++ } END { exit good > 0 ? 0 : 1 }' \
  "$tmp/file_cov.txt" || fail "no pose with a positive covariance"

step "pose_listener --tum FILE | head -n 3 (the README's line: stdout closes early)"
"$tmp/example/pose_listener" --log "$tmp/run.lcm" --tum "$tmp/head.txt" | head -n 3 > /dev/null
cmp "$tmp/run.txt" "$tmp/head.txt" || fail "pose_listener lost its --tum file when stdout closed"

step "pose_listener --replay-memq"
"$tmp/example/pose_listener" --replay-memq "$tmp/run.lcm" --tum "$tmp/memq.txt" > /dev/null
cmp "$tmp/run.txt" "$tmp/memq.txt" || fail "memq:// trajectory differs from pplvo-run's"

step "the same source with pkg-config"
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
# shellcheck disable=SC2046
g++ -std=c++17 -O1 "$prefix/share/pplvo/examples/cpp/pose_listener.cpp" -o "$tmp/pc_listener" \
  $(pkg-config --cflags --libs pplvo) || fail "pkg-config build"
"$tmp/pc_listener" --log "$tmp/run.lcm" --tum "$tmp/pc.txt" > /dev/null
if ldd "$tmp/pc_listener" | grep -E 'opencv|ceres'; then
  fail "the pkg-config build of pose_listener loads libraries it does not use"
fi
cmp "$tmp/run.txt" "$tmp/pc.txt" || fail "pkg-config build: trajectory differs"
[[ $(pkg-config --cflags pplvo-msgs) == *"$prefix/lib/pkgconfig/../../include"* ]] ||
  fail "pplvo-msgs.pc: unexpected Cflags $(pkg-config --cflags pplvo-msgs)"

step "every installed header against the prefix alone (no header of the source tree missing)"
(cd "$prefix/include" && find pplvo pplvo_msgs -name '*.h' -o -name '*.hpp' | sort |
  sed 's/.*/#include "&"/') > "$tmp/all_headers.cpp"
[[ $(wc -l < "$tmp/all_headers.cpp") -ge 50 ]] || fail "only $(wc -l < "$tmp/all_headers.cpp") headers"
# shellcheck disable=SC2046
g++ -std=c++17 -fsyntax-only $(pkg-config --cflags pplvo) "$tmp/all_headers.cpp" ||
  fail "the installed headers do not compile with the prefix's include folder"

step "installed Python package"
PYTHONPATH=$prefix/lib/python3/dist-packages python3 \
  "$prefix/share/pplvo/examples/python/pplvo_log_to_tum.py" "$tmp/run.lcm" \
  --output "$tmp/py.txt" --covariance "$tmp/py_cov.txt"
python3 "$src/tests/install/compare_tum.py" "$tmp/run.txt" "$tmp/py.txt" --min-poses 25
cmp "$tmp/file_cov.txt" "$tmp/py_cov.txt" || fail "Python and C++ covariances differ"
echo "PASS"
