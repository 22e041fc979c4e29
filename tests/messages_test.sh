#!/usr/bin/env bash
# Issue 14, defect 10 (host preset, ~1 s): the tools' messages name the file, the camera or the
# limit, and navd's documented --rate-hz default holds.
#   1. mfns-navd replays a folder without truth.csv with no --rate-hz (--help: default 18.6);
#      it exited 1 with "bad configuration".
#   2. A camera folder missing: one line naming the folder (was a bare "open failed").
#   3. mfns-flash given a directory or a FIFO as the blob: says which (was "no such file"), never
#      blocks on the FIFO.
#   4. mfns-calib inspect of a file one byte over the blob limit (32768) quotes the limit.
# Usage: messages_test.sh MFNS_CALIB MFNS_NAVD MFNS_FLASH WORK_DIR
set -euo pipefail
calib=$1 navd=$2 flash=$3 work=$4
fail() { echo "FAIL: $*" >&2; exit 1; }
one_line() { [[ $(printf '%s\n' "$1" | wc -l) == 1 ]] || fail "not one line: $1"; }

rm -rf "$work"
mkdir -p "$work"
"$calib" paper-rig --out "$work/paper.yaml" 2>/dev/null
"$calib" blob "$work/paper.yaml" --out "$work/rig.bin" --generation 7 2>/dev/null

# 1. Two dark frame sets, no truth.csv, no --rate-hz.
for cam in x y z; do
  mkdir -p "$work/replay/frames/$cam"
  for f in 0 1; do
    { printf 'P5\n1280 1024\n255\n'; head -c $((1280 * 1024)) /dev/zero; } >"$work/replay/frames/$cam/00000$f.pgm"
  done
done
rc=0
err=$("$navd" --params "$work/rig.bin" --source "replay:$work/replay" --log "$work/p.csv" --pid-file "" --quiet 2>&1) || rc=$?
[[ $rc == 0 ]] || fail "navd without truth.csv and --rate-hz: exit $rc: $err"
[[ $(tail -n +2 "$work/p.csv" | wc -l) == 2 ]] || fail "expected 2 logged frame sets"
# Timed by 18.6 Hz: frame 1 at round(1e9 / 18.6) ns.
[[ $(sed -n 3p "$work/p.csv" | cut -d, -f2) == 53763441 ]] || fail "frame 1 not timed at 18.6 Hz: $(sed -n 3p "$work/p.csv")"

# 2. Camera y's folder missing.
mkdir -p "$work/partial/frames"
cp -r "$work/replay/frames/x" "$work/partial/frames/x"
rc=0
err=$("$navd" --params "$work/rig.bin" --source "replay:$work/partial" --pid-file "" --quiet 2>&1) || rc=$?
[[ $rc == 1 ]] || fail "navd with a camera folder missing: exit $rc"
one_line "$err"
[[ $err == *"open failed: $work/partial/frames/y: No such file or directory"* ]] || fail "camera folder not named: $err"

# 3. mfns-flash with a directory or a FIFO for the blob.
mkfifo "$work/fifo"
rc=0
err=$(timeout 10 "$flash" "$work/replay" "$work/store" 2>&1) || rc=$?
[[ $rc == 1 && $err == "mfns-flash: $work/replay: is a directory, expected a file" ]] || fail "flash DIR: exit $rc: $err"
rc=0
err=$(timeout 10 "$flash" "$work/fifo" "$work/store" 2>&1) || rc=$?
[[ $rc == 1 && $err == "mfns-flash: $work/fifo: not a regular file (a FIFO, socket or device)" ]] ||
  fail "flash FIFO: exit $rc: $err"

# 4. inspect of a file one byte above the blob limit.
head -c 32769 /dev/zero >"$work/big.bin"
rc=0
err=$("$calib" inspect "$work/big.bin" 2>&1) || rc=$?
[[ $rc == 1 && $err == "mfns-calib: $work/big.bin: too large (32769 bytes, limit 32768)" ]] || fail "inspect: exit $rc: $err"
echo PASS
