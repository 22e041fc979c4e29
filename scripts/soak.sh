#!/usr/bin/env bash
# The soak of issue 14 item 4: 10^5 frame sets (or $1) through NavLoop with every output on
# (trigger, UDP, poses log) and faults mixed in (blank and saturated frames, timeouts, a camera
# stalled for 30 frame sets every 1009, repeated timestamps): zero heap allocations after
# start, resident memory flat, every fault counted, no wrong fix, no deadline slip
# (NavLoop.SoakWithFaultsAndEveryOutput, firmware/app/navd/nav_loop_test.cc; CI runs it with
# 3000 frame sets). Uses an existing host build (cmake --preset host && cmake --build build/host).
# Usage: scripts/soak.sh [FRAME_SETS]   Result: docs/reliability.md.
set -euo pipefail
cd "$(dirname "$0")/.."
sets=${1:-100000}
test_bin=build/host/tests/navd_test
[[ -x $test_bin ]] || { echo "soak.sh: $test_bin missing: build the host preset first" >&2; exit 1; }
MFNS_SOAK_FRAME_SETS=$sets /usr/bin/time -f "soak: peak RSS %M kB, %e s wall, %U s user" \
  "$test_bin" --gtest_filter=NavLoop.SoakWithFaultsAndEveryOutput 2>&1 | grep -E "soak:|OK|FAILED|Failure|Which"
