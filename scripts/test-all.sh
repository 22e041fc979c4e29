#!/usr/bin/env bash
# Installs what is missing, builds and runs every test suite: host, host-asan, aarch64
# (cross-compiled, run under qemu-aarch64), fuzz (each libFuzzer target for
# MFNS_FUZZ_SECONDS, tests/fuzz) and board (scripts/test-board.sh: mfns-navd on Debian's arm64
# kernel in qemu-system-aarch64 with the vivid and PL061 drivers, docs/board.md). Exits
# non-zero if any build or test fails.
# Usage: scripts/test-all.sh [preset ...]   (default: host host-asan aarch64 fuzz board)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh

presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(host host-asan aarch64 fuzz board)
jobs=$(nproc)
total_pass=0
total_fail=0
total_skip=0
for preset in "${presets[@]}"; do
  start=$(date +%s)
  if [ "${preset}" = board ]; then
    # Not a CMake preset: the emulated board builds what it needs (aarch64 navd, host mfns-calib).
    echo "=== board: scripts/test-board.sh" >&2
    log=$(mktemp)
    status=0
    bash scripts/test-board.sh 2>&1 | tee "${log}" || status=$?
    line=$(grep -E '^board: [0-9]+ passed, [0-9]+ failed$' "${log}" | tail -n 1 || true)
    rm -f "${log}"
    if [ -z "${line}" ]; then
      echo "=== board: scripts/test-board.sh printed no summary" >&2
      exit 1
    fi
    passed=$(sed -E 's/^board: ([0-9]+) passed, ([0-9]+) failed$/\1/' <<<"${line}")
    failed=$(sed -E 's/^board: ([0-9]+) passed, ([0-9]+) failed$/\2/' <<<"${line}")
    total_pass=$((total_pass + passed))
    total_fail=$((total_fail + failed))
    echo "=== board: ${passed} passed, 0 skipped, ${failed} failed in $(( $(date +%s) - start )) s" >&2
    if [ "${status}" -ne 0 ]; then
      echo "total: ${total_pass} passed, ${total_skip} skipped, ${total_fail} failed"
      exit "${status}"
    fi
    continue
  fi
  echo "=== ${preset}: configure and build" >&2
  cmake --preset "${preset}" >/dev/null
  cmake --build --preset "${preset}" -j "${jobs}"
  echo "=== ${preset}: test" >&2
  log=$(mktemp)
  status=0
  ctest --preset "${preset}" -j "${jobs}" 2>&1 | tee "${log}" || status=$?
  line=$(grep -E "tests passed, [0-9]+ tests failed out of [0-9]+" "${log}" | tail -n 1 || true)
  # ctest counts a skipped test (GTEST_SKIP, a missing tool) among the passed ones; it lists
  # them under "The following tests did not run:" as "(Skipped)" or "(Disabled)".
  skipped=$(grep -cE '^[[:space:]]*[0-9]+ - .* \((Skipped|Disabled)\)$' "${log}" || true)
  rm -f "${log}"
  if [ -z "${line}" ]; then
    echo "=== ${preset}: ctest printed no summary" >&2
    exit 1
  fi
  failed=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\1/' <<<"${line}")
  count=$(sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\2/' <<<"${line}")
  total_fail=$((total_fail + failed))
  total_skip=$((total_skip + skipped))
  total_pass=$((total_pass + count - failed - skipped))
  echo "=== ${preset}: $((count - failed - skipped)) passed, ${skipped} skipped, ${failed} failed in $(( $(date +%s) - start )) s" >&2
  if [ "${status}" -ne 0 ]; then
    echo "total: ${total_pass} passed, ${total_skip} skipped, ${total_fail} failed"
    exit "${status}"
  fi
done
echo "total: ${total_pass} passed, ${total_skip} skipped, ${total_fail} failed"
