#!/usr/bin/env bash
# CTest demo_pipeline_short: the demo pipeline of scripts/demo.sh on 30 frame sets (and the
# calibration's fast corner detection) with the already-built tools, then checks that it exited 0, printed both tables with numbers and wrote
# the HTML report with its four plots.
#   demo_test.sh SOURCE_DIR BIN_DIR WORK_DIR
set -euo pipefail
src=$1 bin=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
bash "$src/scripts/demo.sh" --no-build --bin "$bin" --frames 30 --fast-detect --threads 2 --out "$work/demo" > "$work/stdout.txt"
cat "$work/stdout.txt"
fail() { echo "demo_test: $*" >&2; exit 1; }
grep -q '^Table 5: navigation error' "$work/stdout.txt" || fail "no Table 5 on stdout"
grep -q '^Table 3: camera-to-body calibration error' "$work/stdout.txt" || fail "no Table 3 on stdout"
for axis in x_mm y_mm z_mm roll_deg pitch_deg yaw_deg; do
  grep -Eq "^  $axis +-?[0-9]" "$work/stdout.txt" || fail "Table 5 has no row for $axis"
done
for cam in x y z; do
  grep -Eq "^  $cam +\|rotation\|_deg +\| [+-][0-9]" "$work/stdout.txt" || fail "Table 3 has no rotation error for camera $cam"
done
html="$work/demo/report.html"
[ -s "$html" ] || fail "no $html"
for id in pose-error-position pose-error-attitude beacons-per-camera residuals; do
  grep -q "<svg [^>]*id=\"$id\"" "$html" || fail "report.html has no plot $id"
done
# Issue 16's stages: the second recording navigated with the surveyed and the refined map.
grep -q '^Second recording, the map surveyed' "$work/stdout.txt" || fail "no survey comparison on stdout"
grep -Eq '^  x_mm .*\| +-?[0-9.]+ +[0-9.]+ +[0-9.]+ \| +-?[0-9.]+ +[0-9.]+ +[0-9.]+$' <(sed -n '/^Second recording/,$p' "$work/stdout.txt") ||
  fail "the survey's Table 5 has no x_mm row for both maps"
for f in survey/rig.yaml survey/calibration.bin survey/survey.csv survey/report.html report-survey.html; do
  [ -s "$work/demo/$f" ] || fail "no $work/demo/$f"
done
echo "demo_test: tables and report present"
