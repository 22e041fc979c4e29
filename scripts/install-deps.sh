#!/usr/bin/env bash
# Idempotent install of everything MFNS needs on Debian 12 (bookworm), from Debian packages only.
# Enables the arm64 architecture for the cross libraries (libgpiod) used by the aarch64 preset.
# Safe to run again: it installs only what is missing and exits quickly when nothing is.
set -euo pipefail

HOST_PKGS=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libeigen3-dev libceres-dev libopencv-dev libapriltag-dev
  libgpiod-dev gpiod libyaml-cpp-dev libcli11-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  g++-aarch64-linux-gnu qemu-user
  clang libclang-rt-14-dev  # the fuzz preset: libFuzzer, ASan, UBSan (tests/fuzz)
  openssh-server openssh-client dpkg-dev file
  chromium  # headless checks of report.html (host/calib/app/rig_command_test) and mfns-view's page (host/view)
  nlohmann-json3-dev libcpp-httplib-dev  # mfns-view: the page's JSON and its HTTP server (host/view)
  qemu-system-arm kmod cpio  # scripts/test-board.sh: the emulated arm64 board, depmod, the initramfs
)
ARM64_PKGS=(libgpiod-dev:arm64 libgpiod2:arm64 libbenchmark-dev:arm64)  # benchmark: aarch64 benchmarks (scripts/bench.sh)
ARM64_PKGS+=(libstdc++6:arm64)  # scripts/test-board.sh copies the libraries mfns-navd links into the board's initramfs
# COMMAND:PACKAGE pairs installed from Debian only when the command is missing: node and npm for
# the ctest navd_mavlink (tests/mavlink installs node-mavlink from the npm registry). A machine
# may have them from elsewhere (NodeSource's nodejs bundles npm and conflicts with Debian's npm
# package, which apt would resolve by removing it).
CMD_PKGS=(node:nodejs npm:npm)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${HOST_PKGS[@]}" "${ARM64_PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
for cp in "${CMD_PKGS[@]}"; do
  command -v "${cp%%:*}" >/dev/null || missing+=("${cp#*:}")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present" >&2
  exit 0
fi

echo "install-deps: installing ${missing[*]}" >&2
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  $SUDO dpkg --add-architecture arm64
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done" >&2
