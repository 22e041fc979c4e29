#!/usr/bin/env bash
# Table 5 over many draws of the beacon survey error (docs/replication.md): the sweep of a demo
# run (its images, so its centroid noise) navigated with N independently surveyed beacon maps
# (0.4 mm, the map of `mfns-sim render --seed S`), by both pipelines:
#   ours   ml cameras + map S -> blob -> mfns-navd (automatic identification, robust GN)
#   paper  CPC cameras + map S -> mfns-sim solve-given (Newton, true correspondences)
# and prints per pipeline and axis the RMS over draws of the sweep's std and of its mean.
#   host/report/tools/table5_map_draws.sh BIN_DIR DEMO_OUT [N] [extra mfns-sim report options]
# DEMO_OUT is the --out of scripts/demo.sh (sweep/, calib-ml/, calib-paper/). mfns-navd starts
# from the turntable's home pose like the demo (--initial-pose 0,0,0,0,0,0); COLD_START=1 in the
# environment drops it (lost-in-space and the acquisition instead).
set -euo pipefail
bin=${1:?BIN_DIR (e.g. build/host/bin)}
demo=${2:?DEMO_OUT (e.g. out/demo)}
n=${3:-20}
start_pose=(--initial-pose 0,0,0,0,0,0)
[ "${COLD_START:-0}" = 1 ] && start_pose=()
shift $(( $# < 3 ? $# : 3 ))
work="$demo/map-draws"
mkdir -p "$work"
for s in $(seq 1 "$n"); do
  d="$work/map-$s"
  if [ ! -f "$d/believed-rig.yaml" ]; then
    "$bin/mfns-sim" render --scenario "$demo/sweep-scenario.yaml" --frames 1 --seed "$s" --no-images --out "$d" > /dev/null 2>&1
  fi
  "$bin/mfns-sim" merge-rig --cameras "$demo/calib-ml/rig.yaml" --beacons "$d/believed-rig.yaml" --out "$d/ml.yaml" 2> /dev/null
  "$bin/mfns-sim" merge-rig --cameras "$demo/calib-paper/rig.yaml" --beacons "$d/believed-rig.yaml" --out "$d/cpc.yaml" 2> /dev/null
  "$bin/mfns-calib" blob "$d/ml.yaml" --out "$d/ml.bin" --generation "$s" 2> /dev/null
  "$bin/mfns-navd" --params "$d/ml.bin" --source "replay:$demo/sweep" --log "$d/navd.csv" --pid-file '' --quiet \
    "${start_pose[@]}" 2> /dev/null
  "$bin/mfns-sim" solve-given "$demo/sweep" --rig "$d/cpc.yaml" --out "$d/given.csv" > /dev/null
  "$bin/mfns-sim" report --sim "$demo/sweep" --poses "ours=$d/navd.csv" --poses "paper=$d/given.csv" "$@" 2> /dev/null |
    tee "$d/table5.txt" | sed -n '3,8p' | sed "s/^/draw $s:/"
done | awk '
  # draw S: AXIS pub_mean pub_std | mean std crb | mean std crb
  { axis = $3; m1[axis] += $7 * $7; s1[axis] += $8 * $8; b1[axis] += $9 * $9
    m2[axis] += $11 * $11; s2[axis] += $12 * $12; b2[axis] += $13 * $13; n[axis]++ }
  END {
    printf "over %d map draws: RMS of the per-sweep mean and std (mm, deg)\n", n["x_mm"]
    printf "  %-10s %10s %10s %10s | %10s %10s %10s\n", "axis", "ours mean", "std", "CRB rms", "paper mean", "std", "CRB rms"
    split("x_mm y_mm z_mm roll_deg pitch_deg yaw_deg", axes, " ")
    for (i = 1; i <= 6; i++) { a = axes[i]
      printf "  %-10s %10.4f %10.4f %10.4f | %10.4f %10.4f %10.4f\n", a, sqrt(m1[a] / n[a]), sqrt(s1[a] / n[a]), sqrt(b1[a] / n[a]),
             sqrt(m2[a] / n[a]), sqrt(s2[a] / n[a]), sqrt(b2[a] / n[a]) }
  }'
