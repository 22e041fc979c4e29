#!/usr/bin/env bash
# Errors of every calibration method against the simulation truth over seeds (docs/calibration.md):
#   host/calib/tools/compare_methods.sh BIN_DIR WORK_DIR [SEEDS] [PRESET] [extra mfns-calib options]
# For seed 1..SEEDS: `mfns-sim calib-dataset --preset PRESET --seed S`, then
# `mfns-calib rig --compare` (ml, paper and opencv-handeye on the same detected corners); prints
# the RMS over seeds and cameras of the C_k_b angle error and the r_b_bk position error, and the
# share of ml's parameters within 3 sigma.
set -euo pipefail
bin=${1:?BIN_DIR (e.g. build/host/bin)}
work=${2:?WORK_DIR}
seeds=${3:-20}
preset=${4:-paper-calibration}
shift $(( $# < 4 ? $# : 4 ))
mkdir -p "$work"
for s in $(seq 1 "$seeds"); do
  if [ ! -f "$work/data-$s/images.csv" ]; then
    "$bin/mfns-sim" calib-dataset --preset "$preset" --seed "$s" --out "$work/data-$s" 2> "$work/sim-$s.log"
  fi
  "$bin/mfns-calib" rig "$work/data-$s" --out "$work/out-$s" --generation "$s" --compare "$@" 2> "$work/calib-$s.log"
  echo "seed $s: $(grep -A3 '^compare' "$work/calib-$s.log" | tail -3 | tr '\n' ' ')" >&2
done
cat "$work"/out-*/compare.csv | awk -F, '
  $1 != "method" { n[$1]++; r[$1] += $3 * $3; p[$1] += $4 * $4 }
  END { for (m in n) printf "%-15s C_k_b RMS %.5f deg  r_b_bk RMS %.4f mm  (%d camera results)\n", m, sqrt(r[m] / n[m]), sqrt(p[m] / n[m]), n[m] }' | sort
awk -F, '$1 == "ml" && !done[FILENAME] { w += $5; t += $6; done[FILENAME] = 1 }
         END { if (t > 0) printf "ml parameters within 3 sigma: %d/%d (%.1f%%)\n", w, t, 100 * w / t }' "$work"/out-*/compare.csv
