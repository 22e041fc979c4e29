#!/usr/bin/env bash
# Issue 14 (host preset, ~1-2 s): mfns-navd's poses log never replaces a good log with a
# bad one, and mfns-calib refuses a blob navd cannot navigate with.
#   1. mfns-calib blob of a rig with 0 beacons: exit 1, one line naming the rig file, no blob.
#   2. --log on a "full disk" (a 250-byte file-size limit, prlimit): navd exits 1 with one line
#      naming the log, and the previous poses.csv is untouched.
#   3. The same run without the limit: exit 0 and poses.csv replaced by the new, complete log.
#   4. A map that repeats itself (a regular grid on two walls): mfns-calib blob writes the blob
#      and warns, naming the rig file; mfns-navd warns once at start and navigates as before.
# Usage: navd_log_test.sh MFNS_CALIB MFNS_NAVD WORK_DIR
set -euo pipefail
calib=$1 navd=$2 work=$3
fail() { echo "FAIL: $*" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"

# 1. A rig without beacons.
"$calib" paper-rig --out "$work/paper.yaml" 2>/dev/null
awk '/^beacons_mm:/ {print "beacons_mm: []"; skip = 1; next} skip && /^  - / {next} {skip = 0; print}' \
  "$work/paper.yaml" >"$work/no-beacons.yaml"
grep -q '^beacons_mm: \[\]$' "$work/no-beacons.yaml" || fail "could not make the rig without beacons"
rc=0
err=$("$calib" blob "$work/no-beacons.yaml" --out "$work/none.bin" 2>&1) || rc=$?
[[ $rc == 1 ]] || fail "mfns-calib blob of a rig without beacons: exit $rc (expected 1): $err"
[[ $(printf '%s\n' "$err" | wc -l) == 1 && $err == *no-beacons.yaml* ]] || fail "not one line naming the rig: $err"
[[ ! -e $work/none.bin ]] || fail "a blob was written for a rig without beacons"

# 2. A full disk while logging.
# Five dark frame sets of the paper rig (navd logs a lost row for each; no rendering needed).
for cam in x y z; do
  mkdir -p "$work/render/frames/$cam"
  for f in 0 1 2 3 4; do
    { printf 'P5\n1280 1024\n255\n'; head -c $((1280 * 1024)) /dev/zero; } >"$work/render/frames/$cam/00000$f.pgm"
  done
done
printf 'frame,t_ns\n0,1000000000\n1,1100000000\n2,1200000000\n3,1300000000\n4,1400000000\n' >"$work/render/truth.csv"
"$calib" blob "$work/paper.yaml" --out "$work/rig.bin" 2>/dev/null
old=$'frame,t_ns,status\n0,1,fix'
# Twice: SIGXFSZ as navd inherits it by default (it would kill navd unless navd ignores it) and
# ignored by the parent (as the issue found it: navd then exited 0 and renamed the cut log).
for xfsz in default ignored; do
  printf '%s\n' "$old" >"$work/poses.csv"
  rc=0
  # stderr through a pipe: the file-size limit applies to files only.
  err=$( (if [[ $xfsz == ignored ]]; then trap '' XFSZ; fi
          prlimit --fsize=250 "$navd" --params "$work/rig.bin" --source "replay:$work/render" \
            --log "$work/poses.csv" --pid-file "" --quiet) 2>&1) || rc=$?
  [[ $rc == 1 ]] || fail "navd with a full disk (SIGXFSZ $xfsz): exit $rc (expected 1): $err"
  [[ $(cat "$work/poses.csv") == "$old" ]] || fail "the previous poses.csv was replaced (SIGXFSZ $xfsz)"
  last=$(printf '%s\n' "$err" | tail -n 1)
  [[ $last == *"log $work/poses.csv not written"* ]] || fail "last line does not name the log: $last"
done

# 3. The same run with room: the log is replaced by the complete new one.
"$navd" --params "$work/rig.bin" --source "replay:$work/render" --log "$work/poses.csv" --pid-file "" --quiet \
  2>"$work/navd.log" || { cat "$work/navd.log"; fail "navd"; }
rows=$(tail -n +2 "$work/poses.csv" | wc -l)
[[ $rows == 5 ]] || fail "poses.csv has $rows rows, expected 5"
[[ ! -e $work/poses.csv.partial ]] || fail "poses.csv.partial left after a good run"

# 4. A regular map: 5 x 4 beacons 400 mm apart on two facing walls.
awk '/^beacons_mm:/ {print; for (w = -1; w <= 1; w += 2) for (a = 0; a < 5; ++a) for (b = 0; b < 4; ++b)
       printf "  - [%d, %d, %d]\n", -800 + 400 * a, 1500 * w, -600 + 400 * b; skip = 1; next}
     skip && /^  - / {next} {skip = 0; print}' "$work/paper.yaml" >"$work/grid.yaml"
err=$("$calib" blob "$work/grid.yaml" --out "$work/grid.bin" 2>&1) || fail "mfns-calib blob of a regular map: $err"
[[ -s $work/grid.bin ]] || fail "no blob written for a regular map"
[[ $err == *"warning: $work/grid.yaml: the beacon map repeats itself"* ]] || fail "no warning naming the rig: $err"
"$navd" --params "$work/grid.bin" --source "replay:$work/render" --pid-file "" --quiet 2>"$work/grid.log" ||
  { cat "$work/grid.log"; fail "navd on a regular map"; }
[[ $(grep -c 'warning: the beacon map repeats itself: 40 of 40 beacons' "$work/grid.log") == 1 ]] ||
  fail "navd did not warn once about the regular map: $(cat "$work/grid.log")"
# The paper's map does not repeat.
if grep -q 'repeats itself' "$work/navd.log"; then fail "a warning for the paper's map"; fi
echo PASS
