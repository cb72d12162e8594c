#!/usr/bin/env bash
# Installs every Debian package pplvo needs to build, test and run. Idempotent: apt-get skips
# what is already installed. Run as root (or with sudo available).
set -euo pipefail

packages=(
  # toolchain (dpkg-dev: dpkg-shlibdeps for the Depends of cpack's Debian package)
  build-essential cmake pkg-config git dpkg-dev
  # messaging: LCM 1.3.1 (library, lcm-gen, lcm-logplayer, lcm-spy's jar) and a JDK for the types jar
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev default-jdk-headless
  # pplvo-spy: lcm-spy's window needs a JRE with AWT (default-jre) and its charts jchart2d
  libjchart2d-java default-jre
  # algorithms
  libeigen3-dev libopencv-dev libopencv-contrib-dev libceres-dev libyaml-cpp-dev zlib1g-dev
  libdeflate-dev libturbojpeg0-dev
  # camera drivers
  libopenni2-dev libfreenect-dev libfreenect-bin
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-numpy
  # private network namespaces for multi-process tests (ip, unshare)
  iproute2 util-linux procps
  # headless viewer checks
  xvfb xauth
  # fuzzing (scripts/fuzz.sh): clang with libFuzzer and the sanitizer runtimes
  clang libclang-rt-14-dev
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# LCM over UDP multicast (pplvo-launch, processes on a network) drops full VGA frames when
# the kernel's socket receive buffer limit is the usual 208 KiB: LCM's own advice is to raise
# net.core.rmem_max (docs/launch.md). Raise it to 4 MiB if lower, now and at boot.
raise_rmem_max() {
  local want=4194304 have
  have=$(cat /proc/sys/net/core/rmem_max 2>/dev/null || echo "$want")
  if [ "$have" -ge "$want" ]; then return 0; fi
  if $SUDO sysctl -q -w net.core.rmem_max=$want net.core.rmem_default=$want 2>/dev/null; then
    echo "net.core.rmem_max=$want" | $SUDO tee /etc/sysctl.d/60-pplvo-lcm.conf >/dev/null || true
    echo "install_deps: net.core.rmem_max raised from $have to $want (LCM over UDP)"
  else
    echo "install_deps: warning: cannot raise net.core.rmem_max ($have): pplvo-launch falls back" \
         "to compressed frames (docs/launch.md)" >&2
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} packages already installed"
else
  echo "install_deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
raise_rmem_max
