#!/usr/bin/env bash
# Issue 4, "Must show" (label slow, host preset): the paper's turntable sweep rendered by the
# simulator (centroid noise only), a blob of the true rig, mfns-navd replaying the frames with
# automatic identification, twice:
#   1. no prior (the command, with --three-beacon-fixes: the paper's lab), from the
#      first fix on, a fix in every frame set that
#      sees >= 3 beacons (3 px inside the image); the frame sets before it are the acquisition
#      (with 3-4 beacons in view and no prior, tens of poses explain the blobs exactly, and only
#      the motion, over ~20 frame sets, refutes all but one): counted, printed, fewer than 40;
#   2. --initial-pose (the dock pose, off by 5 mm / 0.5 deg): a fix in every such frame set
#      from the very first;
#   and in both, position and attitude RMS errors (mfns-sim compare: over the fixed frame sets)
#   within 1.5x the Cramér-Rao bound of those frame sets, per axis.
# Usage: navd_must_show_test.sh MFNS_SIM MFNS_CALIB MFNS_NAVD WORK_DIR [FRAMES]
set -euo pipefail
sim=$1 calib=$2 navd=$3 work=$4 frames=${5:-360}
fail() { echo "FAIL: $*" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"
d=$work/render
"$sim" render --preset paper-turntable --frames "$frames" --out "$d" >"$work/render.log" 2>&1 ||
  { cat "$work/render.log"; fail "mfns-sim render"; }
tail -n 1 "$work/render.log"

# Centroid noise is the only error source: the preset must keep every other one off.
# (turntable_axis draws only the turntable's surveyed placement, turntable-survey.yaml, which
# neither the images nor the navigator see.)
enabled=$(awk '/^errors:/ {e = 1; next} e && /^[^ ]/ {e = 0} e && /enabled: true/ {sub(/:.*/, ""); gsub(/ /, ""); print}' \
  "$d/scenario.yaml" | grep -vx turntable_axis)
[[ "$enabled" == "pixel_noise" ]] || fail "error sources enabled: '$enabled' (expected pixel_noise only)"

"$calib" blob "$d/rig.yaml" --out "$work/true.bin" >/dev/null
width=$(awk '/width:/ {print $2; exit}' "$d/rig.yaml")
height=$(awk '/height:/ {print $2; exit}' "$d/rig.yaml")

# Fixes against the beacons in view. A beacon counts as seen when its true image centre
# (blobs.csv) is 3 px (3 PSF sigmas) inside the image: nearer the edge its spot is cut by the
# border and the detector refuses it (its centroid would be biased). The frame sets this
# excludes, among those the simulator counts with >= 3 beacons in the image (crb.csv), are
# printed. check_fixes POSES MAX_FIRST: every frame set with >= 3 beacons seen from the first
# fix on has a fix, and the first fix comes before frame set MAX_FIRST; the frame sets with
# >= 3 beacons seen before it (the acquisition) are counted.
check_fixes() {
  awk -F, -v W="$width" -v H="$height" -v MAX_FIRST="$2" '
    FNR == 1 { next }
    FILENAME == ARGV[1] { in_image[$1] = $3; next }
    FILENAME == ARGV[2] {
      if ($6 >= 3 && $6 <= W - 4 && $7 >= 3 && $7 <= H - 4) ++seen[$1]
      next
    }
    { status[$1] = $3; n = $1 + 1 > n ? $1 + 1 : n }
    END {
      first = -1
      for (f = 0; f < n; ++f) if (status[f] != "lost") { first = f; break }
      before = 0; eligible = 0; fixed = 0; missed = ""; edge = ""
      for (f = 0; f < n; ++f) {
        if (in_image[f] >= 3 && seen[f] < 3) edge = edge " " f
        if (seen[f] < 3) continue
        if (first < 0 || f < first) { ++before; continue }
        ++eligible
        if (status[f] == "fix") ++fixed; else missed = missed " " f
      }
      printf "frame sets %d; first fix at frame set %d (acquisition: %d frame sets with >= 3 beacons seen before it); " \
             "after it: fix in %d of %d frame sets with >= 3 beacons seen\n", n, first, before, fixed, eligible
      printf "frame sets with >= 3 beacons in the image but one within 3 px of its edge (not counted):%s\n", \
             edge == "" ? " none" : edge
      if (first < 0 || first >= MAX_FIRST) { print "FAIL: no fix before frame set " MAX_FIRST; exit 1 }
      if (fixed != eligible) { print "FAIL: no fix in frame sets" missed; exit 1 }
    }' "$d/crb.csv" "$d/blobs.csv" "$1"
}

# Errors against truth and the Cramér-Rao bound of the fixed frame sets (mfns-sim compare).
check_accuracy() {
  "$sim" compare "$d" "$1" | tee "$1.compare.txt"
  awk '
    $1 ~ /_(mm|deg)$/ && NF == 6 {
      ++axes
      if ($6 + 0 > 1.5) { printf "FAIL: %s RMS %.4f is %.2fx the bound %.4f\n", $1, $4, $6, $5; bad = 1 }
    }
    END { if (axes != 6) { print "FAIL: compare printed " axes " axes"; exit 1 } exit bad }' "$1.compare.txt"
}

# 1. No prior (the command): lost-in-space and the acquisition over frames. With 3-4
#    beacons in view and no prior, tens of poses explain the blobs exactly; only the motion,
#    over ~20 frame sets, refutes all but one: they are counted and printed, and the first
#    fix must come before frame set 40. From it on, a fix in every frame set with >= 3 beacons.
#    The acquisition rests on three beacons: a fix at once only with --three-beacon-fixes (the
#    paper's dark lab, where every light is a beacon; issue 4's criterion).
echo "== no prior, --three-beacon-fixes"
"$navd" --params "$work/true.bin" --source "replay:$d" --log "$work/poses.csv" --pid-file "$work/navd.pid" \
  --quiet --three-beacon-fixes || fail "mfns-navd"
check_fixes "$work/poses.csv" 40 || fail "fixes (no prior)"
check_accuracy "$work/poses.csv" || fail "accuracy (no prior)"

# 1b. The same by default: the same frame sets posed, each pose the same; a track found on three
#     beacons is degraded, reason "unverified", until a pose on four (never right after a fix).
echo "== no prior, default"
"$navd" --params "$work/true.bin" --source "replay:$d" --log "$work/poses-default.csv" --pid-file "" --quiet ||
  fail "mfns-navd (default)"
awk -F, '
  FNR == 1 { next }
  FILENAME == ARGV[1] { lab[$1] = $3; labpose[$1] = $4 "," $5 "," $6; next }
  {
    if (($3 == "lost") != (lab[$1] == "lost")) { printf "FAIL: frame set %d: %s here, %s with three-beacon fixes\n", $1, $3, lab[$1]; bad = 1 }
    if ($3 != "lost" && $4 "," $5 "," $6 != labpose[$1]) { printf "FAIL: frame set %d: another pose\n", $1; bad = 1 }
    if ($3 == "degraded" && lab[$1] == "fix") {
      ++unverified
      if ($12 != "unverified") { printf "FAIL: frame set %d: degraded (%s), a fix with three-beacon fixes\n", $1, $12; bad = 1 }
      if (prev == "fix") { printf "FAIL: frame set %d: unverified right after a fix\n", $1; bad = 1 }
    } else if ($3 != lab[$1]) { printf "FAIL: frame set %d: %s here, %s with three-beacon fixes\n", $1, $3, lab[$1]; bad = 1 }
    prev = $3
  }
  END { printf "default: %d frame sets unverified (degraded) that are fixes with --three-beacon-fixes\n", unverified
        if (unverified == 0) { print "FAIL: no unverified frame set (the acquisition rests on three beacons)"; bad = 1 }
        exit bad }' "$work/poses.csv" "$work/poses-default.csv" || fail "default against --three-beacon-fixes"

# 2. The start pose known (the dock: --initial-pose, here truth's frame set 0 off by 5 mm and
#    0.5 deg on every axis, inside the default 1-sigma of 10 mm and 1 deg): no acquisition, a
#    fix in every frame set with >= 3 beacons seen, from the first one on (with
#    --three-beacon-fixes: the re-acquisition after the sweep's 2.3 s gap with two beacons rests
#    on three; by default it is unverified until a pose on four, as in 1b).
echo "== --initial-pose"
start=$(awk -F, 'NR == 2 {printf "%.4f,%.4f,%.4f,%.6f,%.6f,%.6f", $3 + 5, $4 - 5, $5 + 5, $6 + 0.5, $7 - 0.5, $8 + 0.5}' \
  "$d/truth.csv")
"$navd" --params "$work/true.bin" --source "replay:$d" --log "$work/poses-start.csv" --pid-file "" --quiet \
  --initial-pose "$start" --three-beacon-fixes || fail "mfns-navd --initial-pose $start"
first_seen=$(awk -F, -v W="$width" -v H="$height" 'NR > 1 && $6 >= 3 && $6 <= W - 4 && $7 >= 3 && $7 <= H - 4 {
  if (++seen[$1] == 3) { print $1; exit } }' "$d/blobs.csv")
check_fixes "$work/poses-start.csv" $((first_seen + 1)) || fail "fixes (--initial-pose)"
check_accuracy "$work/poses-start.csv" || fail "accuracy (--initial-pose)"
echo "PASS"
