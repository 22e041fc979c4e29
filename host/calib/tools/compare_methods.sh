#!/usr/bin/env bash
# Errors of every calibration method against the simulation truth over seeds (docs/calibration.md):
#   host/calib/tools/compare_methods.sh BIN_DIR WORK_DIR [SEEDS] [PRESET] [extra mfns-calib options]
# For seed 1..SEEDS: `mfns-sim calib-dataset --preset PRESET --seed S` (kept in WORK_DIR/data-S
# and reused), then `mfns-calib rig --compare` (ml, paper and opencv-handeye on the same corners).
# Prints, per method and camera, the RMS over seeds of the C_k_b rotation error (deg) and of the
# r_b_bk position error (mm), their maxima, and the share of ml's parameters within 3 sigma.
# CORNER_NOISE_PX=S (environment): instead of detecting corners, use the dataset's exact
# corners.csv plus independent Gaussian noise of S px per axis (python3; seed 1000 + S), to
# separate the estimator from the detector.
set -euo pipefail
bin=${1:?BIN_DIR (e.g. build/host/bin)}
work=${2:?WORK_DIR}
seeds=${3:-10}
preset=${4:-paper-calibration}
shift $(( $# < 4 ? $# : 4 ))
noise=${CORNER_NOISE_PX:-}
tag=${noise:+noise-$noise-}
mkdir -p "$work"
for s in $(seq 1 "$seeds"); do
  if [ ! -f "$work/data-$s/images.csv" ]; then
    "$bin/mfns-sim" calib-dataset --preset "$preset" --seed "$s" --out "$work/data-$s" > "$work/sim-$s.log" 2>&1
  fi
  extra=()
  if [ -n "$noise" ]; then
    python3 - "$work/data-$s/corners.csv" "$work/${tag}corners-$s.csv" "$noise" "$s" <<'PY'
import csv, random, sys
src, dst, sigma, seed = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
random.seed(1000 + seed)
with open(dst, 'w') as f:
    f.write('camera,image,corner,u_px,v_px\n')
    for r in csv.DictReader(open(src)):
        f.write('%s,%s,%s,%.6f,%.6f\n' % (r['camera'], r['image'], r['corner'],
                float(r['u_px']) + random.gauss(0, sigma), float(r['v_px']) + random.gauss(0, sigma)))
PY
    extra=(--corners "$work/${tag}corners-$s.csv")
  fi
  "$bin/mfns-calib" rig "$work/data-$s" --out "$work/${tag}out-$s" --generation "$s" --compare "${extra[@]}" "$@" \
    2> "$work/${tag}calib-$s.log"
  echo "seed $s: $(grep -A3 '^compare' "$work/${tag}calib-$s.log" | tail -3 | tr '\n' ' ')" >&2
done
files=()
for s in $(seq 1 "$seeds"); do files+=("$work/${tag}out-$s/compare.csv"); done
echo "preset $preset, seeds 1..$seeds${noise:+, exact corners + ${noise} px noise}: RMS (max) over seeds"
awk -F, '
  $1 != "method" {
    k = $1 " " $2; n[k]++; r[k] += $3 * $3; p[k] += $4 * $4
    if ($3 > rm[k]) rm[k] = $3
    if ($4 > pm[k]) pm[k] = $4
    m = $1; nm[m]++; rr[m] += $3 * $3; pp[m] += $4 * $4
  }
  END {
    for (k in n) printf "%-22s C_k_b %.4f (%.4f) deg   r_b_bk %.3f (%.3f) mm\n", k, sqrt(r[k] / n[k]), rm[k], sqrt(p[k] / n[k]), pm[k]
    for (m in nm) printf "%-22s C_k_b %.4f deg         r_b_bk %.3f mm          (all cameras)\n", m " all", sqrt(rr[m] / nm[m]), sqrt(pp[m] / nm[m])
  }' "${files[@]}" | sort
awk -F, '$1 == "ml" && !done[FILENAME] { w += $5; t += $6; done[FILENAME] = 1 }
         END { if (t > 0) printf "ml parameters within 3 sigma: %d/%d (%.1f%%)\n", w, t, 100 * w / t }' "${files[@]}"
