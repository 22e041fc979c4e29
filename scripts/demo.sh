#!/usr/bin/env bash
# The main job (issue 7): installs what is missing, builds the tools and runs the whole life of
# a flyer in simulation, then prints the paper's Tables 3 and 5 regenerated beside the
# published numbers and writes OUT/report.html with plots. docs/replication.md explains every
# stage and number.
#
#   scripts/demo.sh [OUT] [--out DIR] [--frames N] [--seed S] [--threads N] [--fast-detect]
#                   [--cold-start] [--no-build] [--bin DIR]
#
#   1. calibration dataset   mfns-sim calib-dataset --preset paper-calibration (Section 4.2 with the
#                            paper's error sources: centroid noise, 8 arcsec turntable angles)
#   2. calibration           mfns-calib rig --method ml, and --method paper (CPC) for comparison,
#                            with --refine-corners (--fast-detect: SB corners without ACCURACY
#                            and without the refinement, faster, less exact)
#   3. turntable sweep       mfns-sim render: paper-turntable (Section 5, 1 deg steps) with the
#                            beacon map's 0.4 mm survey error; the TRUE rig renders the frames
#   4. the flyer's blob      the ml cameras + the surveyed map (mfns-sim merge-rig, mfns-calib blob)
#   5. flash                 mfns-flash into the local flyer store OUT/flyer/store
#   6. navigate              mfns-navd --params OUT/flyer/store --source replay:OUT/sweep --log,
#                            starting from the turntable's home pose (--initial-pose 0,0,0,0,0,0:
#                            the sweep starts there); --cold-start: no start pose, lost-in-space
#                            and the acquisition over ~20 frame sets instead
#   7. the paper's pipeline  mfns-sim solve-given: Newton on the true correspondences, CPC rig
#   8. tables + report       mfns-sim report (stdout, OUT/report.html)
#   9. second recording      mfns-sim render: the same station (true and surveyed map), another
#                            noise seed and a sweep starting half a step later (issue 16)
#  10. map survey            mfns-calib survey on the FIRST recording (the flyer's own poses and
#                            identities, then the map refined), --turntable with the turntable's
#                            surveyed centre, mount and levelled axis (--turntable-placement
#                            OUT/sweep/turntable-survey.yaml, drawn about the truth); its blob
#                            flashed (a newer generation)
#  11. the maps compared     mfns-navd on the SECOND recording with the surveyed map and with the
#                            refined one; Table 5 for both (OUT/report-survey.html): the map is
#                            never judged on the frames it was fitted to
#
# Outputs in OUT (default out/demo); each stage's output in OUT/logs/<stage>.log. Progress on
# stderr, the tables on stdout. Exit 1 with a one-line message when a stage fails.
set -euo pipefail
cd "$(dirname "$0")/.."

out=out/demo
frames=360
seed=1
threads=$(nproc)
build=1
bin=build/host/bin
calib_opts=(--refine-corners)
start_pose=(--initial-pose 0,0,0,0,0,0)
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    --fast-detect) calib_opts=(--fast-detect); shift ;;
    --cold-start) start_pose=(); shift ;;
    --bin) bin=$2; shift 2 ;;
    -h|--help) sed -n '2,36p' "$0"; exit 0 ;;
    -*) echo "demo: unknown option $1 (see --help)" >&2; exit 1 ;;
    *) out=$1; shift ;;
  esac
done

t0=$(date +%s)
say() { echo "demo [$(( $(date +%s) - t0 ))s] $*" >&2; }

if [ "$build" = 1 ]; then
  say "install dependencies and build the tools (build/host)"
  bash scripts/install-deps.sh
  cmake --preset host >/dev/null
  cmake --build --preset host -j "$(nproc)" --target mfns-sim mfns-calib mfns-flash mfns-navd mfns-paramctl
fi
for tool in mfns-sim mfns-calib mfns-flash mfns-navd; do
  [ -x "$bin/$tool" ] || { echo "demo: $bin/$tool is missing (build it, or give --bin DIR)" >&2; exit 1; }
done

mkdir -p "$out/logs"
# run STAGE CMD...: the command's stdout and stderr go to OUT/logs/STAGE.log; on failure one line.
run() {
  local stage=$1
  shift
  local log="$out/logs/$stage.log"
  if ! "$@" > "$log" 2>&1; then
    echo "demo: stage '$stage' failed: $(grep -v '^\s*$' "$log" | tail -n 1) (full output: $log)" >&2
    exit 1
  fi
}

# render_sweep STAGE SED GREP SCENARIO SEED DIR: OUT/paper-turntable.yaml edited by SED (checked
# by GREP: the preset's text may change) into SCENARIO, rendered into DIR (replaced).
render_sweep() {
  local stage=$1 edit=$2 check=$3 scenario=$4 render_seed=$5 dir=$6
  sed -e "$edit" "$out/paper-turntable.yaml" > "$scenario"
  grep -q "$check" "$scenario" ||
    { echo "demo: the paper-turntable preset has no line matching '$check' after '$edit'" >&2; exit 1; }
  rm -rf "$dir"
  run "$stage" "$bin/mfns-sim" render --scenario "$scenario" --frames "$frames" --seed "$render_seed" \
    --threads "$threads" --out "$dir"
}

calib="$out/calib-dataset"
sweep="$out/sweep"

say "1/11 calibration dataset: paper-calibration, seed $seed -> $calib"
rm -rf "$calib"
run calib-dataset "$bin/mfns-sim" calib-dataset --preset paper-calibration --seed "$seed" --threads "$threads" --out "$calib"

say "2/11 calibration: mfns-calib rig --method ml and --method paper"
run calib-ml "$bin/mfns-calib" rig "$calib" --out "$out/calib-ml" --method ml --jobs "$threads" ${calib_opts[@]+"${calib_opts[@]}"}
run calib-paper "$bin/mfns-calib" rig "$calib" --out "$out/calib-paper" --method paper --jobs "$threads" ${calib_opts[@]+"${calib_opts[@]}"}

say "3/11 turntable sweep: paper-turntable, $frames frame sets, beacon survey error 0.4 mm -> $sweep"
"$bin/mfns-sim" preset paper-turntable > "$out/paper-turntable.yaml"
render_sweep render 's/^  beacon_map: {enabled: false/  beacon_map: {enabled: true/' \
  '^  beacon_map: {enabled: true, sigma_mm: 0.4}' "$out/sweep-scenario.yaml" "$seed" "$sweep"

say "4/11 the flyer's parameters: ml cameras + surveyed beacon map -> $out/flyer-rig.yaml, blob"
run merge-ml "$bin/mfns-sim" merge-rig --cameras "$out/calib-ml/rig.yaml" --beacons "$sweep/believed-rig.yaml" \
  --out "$out/flyer-rig.yaml"
run blob "$bin/mfns-calib" blob "$out/flyer-rig.yaml" --out "$out/flyer.bin"

say "5/11 flash into the flyer store $out/flyer/store"
mkdir -p "$out/flyer"
run flash "$bin/mfns-flash" "$out/flyer.bin" "$out/flyer/store" --no-signal

say "6/11 navigate: mfns-navd replays $frames frame sets with the store's parameters"
run navd "$bin/mfns-navd" --params "$out/flyer/store" --source "replay:$sweep" --log "$out/navd-poses.csv" \
  --pid-file '' --quiet "${start_pose[@]}"

say "7/11 the paper's pipeline: CPC rig, Newton on the true correspondences"
run merge-paper "$bin/mfns-sim" merge-rig --cameras "$out/calib-paper/rig.yaml" --beacons "$sweep/believed-rig.yaml" \
  --out "$out/paper-flyer-rig.yaml"
run solve-given "$bin/mfns-sim" solve-given "$sweep" --rig "$out/paper-flyer-rig.yaml" --out "$out/given-poses.csv"

say "8/11 tables and report"
if ! "$bin/mfns-sim" report --sim "$sweep" --poses "ours=$out/navd-poses.csv" \
    --poses "CPC+Newton=$out/given-poses.csv" --truth-rig "$calib/truth-rig.yaml" \
    --calib "ml=$out/calib-ml/rig.yaml" --calib "paper=$out/calib-paper/rig.yaml" \
    --html "$out/report.html" 2> "$out/logs/report.log"; then
  echo "demo: stage 'report' failed: $(tail -n 1 "$out/logs/report.log")" >&2
  exit 1
fi
sweep2="$out/sweep2"
say "9/11 second recording: the same station, noise seed $((seed + 1000)), the sweep half a step later -> $sweep2"
cp "$out/sweep-scenario.yaml" "$out/paper-turntable.yaml"
render_sweep render2 's/^  main_start_deg: 0$/  main_start_deg: 0.5/' '^  main_start_deg: 0.5$' \
  "$out/sweep2-scenario.yaml" "$((seed + 1000))" "$sweep2"

say "10/11 map survey: mfns-calib survey on the first recording -> $out/survey, flashed"
generation=$("$bin/mfns-calib" inspect "$out/flyer.bin" | sed -n 's/.*generation \([0-9]*\),.*/\1/p')
[ -n "$generation" ] || { echo "demo: no generation in 'mfns-calib inspect $out/flyer.bin'" >&2; exit 1; }
run survey "$bin/mfns-calib" survey --rig "$out/flyer-rig.yaml" --out "$out/survey" "$sweep" \
  --turntable --turntable-placement "$sweep/turntable-survey.yaml" \
  --generation "$((generation + 1))" --jobs "$threads" "${start_pose[@]}"
run flash-survey "$bin/mfns-flash" "$out/survey/calibration.bin" "$out/flyer/store" --no-signal

say "11/11 the maps compared on the second recording: surveyed (flyer.bin) and refined (the store)"
run navd-surveyed "$bin/mfns-navd" --params "$out/flyer.bin" --source "replay:$sweep2" \
  --log "$out/navd2-surveyed-map.csv" --pid-file '' --quiet "${start_pose[@]}"
run navd-refined "$bin/mfns-navd" --params "$out/flyer/store" --source "replay:$sweep2" \
  --log "$out/navd2-refined-map.csv" --pid-file '' --quiet "${start_pose[@]}"
echo
echo "Second recording, the map surveyed (0.4 mm) and refined by mfns-calib survey from the first:"
if ! "$bin/mfns-sim" report --sim "$sweep2" --poses "surveyed map=$out/navd2-surveyed-map.csv" \
    --poses "refined map=$out/navd2-refined-map.csv" --html "$out/report-survey.html" 2> "$out/logs/report-survey.log"; then
  echo "demo: stage 'report-survey' failed: $(tail -n 1 "$out/logs/report-survey.log")" >&2
  exit 1
fi
say "done: report $out/report.html and $out/report-survey.html, logs in $out/logs"
