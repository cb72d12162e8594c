#!/usr/bin/env bash
# Installs every Debian package pplvo needs to build, test and run. Idempotent: apt-get skips
# what is already installed. Run as root (or with sudo available).
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake pkg-config git
  # messaging: LCM 1.3.1 (library, lcm-gen, lcm-logplayer, lcm-spy's jar) and a JDK for the types jar
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev default-jdk-headless
  # algorithms
  libeigen3-dev libopencv-dev libopencv-contrib-dev libceres-dev libyaml-cpp-dev zlib1g-dev
  # camera drivers
  libopenni2-dev libfreenect-dev libfreenect-bin
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-numpy
  # private network namespaces for multi-process tests (ip, unshare)
  iproute2 util-linux
  # headless viewer checks
  xvfb xauth
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
