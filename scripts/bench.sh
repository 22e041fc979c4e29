#!/usr/bin/env bash
# Builds the benchmarks and runs every measurement of docs/benchmarks.md (issue 7 item 3),
# writing the raw outputs under OUT (default out/bench):
#
#   scripts/bench.sh [--out DIR] [--build-dir DIR] [--jobs N] [--min-time S] [--repetitions N]
#                    [--no-build] [--no-calib] [--arm [--arm-build-dir DIR]]
#
#   OUT/machine.txt            date (UTC), CPU model, cores, build type, compiler, `uptime`
#                              before and after (the load while measuring)
#   OUT/<name>.json / .txt     Google Benchmark JSON and console output of detect_benchmark,
#                              identify_benchmark, solve_benchmark, frame_set_benchmark,
#                              corner_refine_benchmark (host calibration)
#   OUT/navd/                  mfns-navd replaying a rendered paper-turntable sequence (60 frame
#                              sets): time-v.txt (`/usr/bin/time -v`: peak RSS, wall time),
#                              poses.csv, malloc-<N>.txt (malloc calls of whole runs of N frame
#                              sets, with --log and UDP output, counted by
#                              benchmarks/malloc_count.cc through LD_PRELOAD)
#   OUT/calib/                 `mfns-calib rig --method ml` on `mfns-sim calib-dataset --preset
#                              paper-calibration`: time-v.txt and its outputs; the same with
#                              --refine-corners (the demo's calibration): time-v-refined.txt
#   OUT/summary.md             the tables of docs/benchmarks.md (benchmarks/bench_summary.py)
#   OUT/aarch64/               with --arm: the firmware benchmarks cross-built (aarch64 preset,
#                              no OpenCV baselines) and run once under qemu-aarch64 to show they
#                              work; qemu's timings say nothing about the board
#
# Benchmarks are not tests: nothing here is registered with CTest. The machine is shared:
# record the load (machine.txt) next to any number you quote.
set -euo pipefail
cd "$(dirname "$0")/.."

out=out/bench
build_dir=build/bench-host
jobs=2
min_time=0.5
reps=3
build=1
calib=1
arm=0
arm_build_dir=build/bench-arm
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --build-dir) build_dir=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --min-time) min_time=$2; shift 2 ;;
    --repetitions) reps=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    --no-calib) calib=0; shift ;;
    --arm) arm=1; shift ;;
    --arm-build-dir) arm_build_dir=$2; shift 2 ;;
    -h|--help) sed -n '2,27p' "$0"; exit 0 ;;
    *) echo "bench: unknown argument $1 (see --help)" >&2; exit 1 ;;
  esac
done

t0=$(date +%s)
say() { echo "bench [$(( $(date +%s) - t0 ))s] $*" >&2; }
bin=$build_dir/bin
benchmarks=(detect_benchmark identify_benchmark solve_benchmark frame_set_benchmark corner_refine_benchmark)

if [ "$build" = 1 ]; then
  say "configure $build_dir (host preset, MFNS_BUILD_BENCHMARKS=ON) and build with -j$jobs"
  cmake --preset host -B "$build_dir" -DMFNS_BUILD_BENCHMARKS=ON > /dev/null
  cmake --build "$build_dir" -j "$jobs" --target "${benchmarks[@]}" mfns_malloc_count mfns-sim mfns-calib mfns-navd
fi
for b in "${benchmarks[@]}" mfns-sim mfns-calib mfns-navd; do
  [ -x "$bin/$b" ] || { echo "bench: $bin/$b is missing (build it, or drop --no-build)" >&2; exit 1; }
done
[ -x /usr/bin/time ] || { echo "bench: /usr/bin/time is missing (apt-get install time)" >&2; exit 1; }

mkdir -p "$out"
out=$(cd "$out" && pwd)
{
  echo "date_utc: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "cpu_model: $(lscpu | sed -n 's/^Model name: *//p' | head -n 1)"
  echo "cpus: $(nproc)"
  echo "kernel: $(uname -r)"
  echo "build_dir: $build_dir"
  echo "build_type: $(sed -n 's/^CMAKE_BUILD_TYPE:STRING=//p' "$build_dir/CMakeCache.txt")"
  echo "compiler: $(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build_dir/CMakeCache.txt") $("$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build_dir/CMakeCache.txt")" -dumpfullversion)"
  echo "git_commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "benchmark_min_time_s: $min_time"
  echo "benchmark_repetitions: $reps"
  echo "uptime_before: $(uptime)"
} > "$out/machine.txt"

# 1. Google Benchmark programs: JSON for the tables, console text for reading.
for b in "${benchmarks[@]}"; do
  say "run $b"
  "$bin/$b" --benchmark_min_time="$min_time" --benchmark_repetitions="$reps" \
    --benchmark_report_aggregates_only=true \
    --benchmark_out="$out/$b.json" --benchmark_out_format=json > "$out/$b.txt" 2>&1
done

# 2. mfns-navd: peak RSS and allocations of the daemon replaying a rendered sequence.
nav=$out/navd
rm -rf "$nav"
mkdir -p "$nav"
say "render paper-turntable, 60 frame sets"
"$bin/mfns-sim" render --preset paper-turntable --frames 60 --out "$nav/sweep" > "$nav/render.log" 2>&1
"$bin/mfns-calib" blob "$nav/sweep/rig.yaml" --out "$nav/rig.blob" > "$nav/blob.log" 2>&1
navd=("$bin/mfns-navd" --params "$nav/rig.blob" --source "replay:$nav/sweep" --pid-file '' --quiet)
say "mfns-navd under /usr/bin/time -v"
if ! /usr/bin/time -v -o "$nav/time-v.txt" "${navd[@]}" --log "$nav/poses.csv" > "$nav/navd.log" 2>&1; then
  echo "bench: mfns-navd failed: $(tail -n 1 "$nav/navd.log") (see $nav/time-v.txt)" >&2
fi
malloc_lib=$(cd "$build_dir/lib" && pwd)/libmfns_malloc_count.so
if [ -f "$malloc_lib" ]; then
  for n in 10 60; do
    say "mfns-navd malloc count, $n frame sets"
    MFNS_MALLOC_COUNT_OUT="$nav/malloc-$n.txt" LD_PRELOAD="$malloc_lib" "${navd[@]}" --frames "$n" \
      --log "$nav/poses-malloc-$n.csv" --output udp://127.0.0.1:9 > "$nav/navd-malloc-$n.log" 2>&1 || echo "bench: mfns-navd --frames $n failed (malloc count)" >&2
  done
fi

# 3. Calibration wall time: mfns-calib rig --method ml on the simulated paper calibration.
if [ "$calib" = 1 ]; then
  cal=$out/calib
  rm -rf "$cal"
  mkdir -p "$cal"
  say "calibration dataset (paper-calibration)"
  /usr/bin/time -v -o "$cal/dataset-time-v.txt" "$bin/mfns-sim" calib-dataset --preset paper-calibration \
    --out "$cal/dataset" > "$cal/dataset.log" 2>&1
  say "mfns-calib rig --method ml --no-refine-corners --jobs $(nproc) (SB corners)"
  if ! /usr/bin/time -v -o "$cal/time-v.txt" "$bin/mfns-calib" rig "$cal/dataset" --out "$cal/ml" --method ml \
      --no-refine-corners --jobs "$(nproc)" > "$cal/calib.log" 2>&1; then
    echo "bench: mfns-calib rig failed: $(tail -n 1 "$cal/calib.log") (not measured)" >&2
  fi
  say "mfns-calib rig --method ml --refine-corners --jobs $(nproc) (the default, the demo's calibration)"
  if ! /usr/bin/time -v -o "$cal/time-v-refined.txt" "$bin/mfns-calib" rig "$cal/dataset" --out "$cal/ml-refined" \
      --method ml --refine-corners --jobs "$(nproc)" > "$cal/calib-refined.log" 2>&1; then
    echo "bench: mfns-calib rig --refine-corners failed: $(tail -n 1 "$cal/calib-refined.log") (not measured)" >&2
  fi
fi

echo "uptime_after: $(uptime)" >> "$out/machine.txt"

# 4. Optional: the aarch64 cross build of the firmware benchmarks, run once under qemu.
if [ "$arm" = 1 ]; then
  say "aarch64 cross build of the firmware benchmarks ($arm_build_dir)"
  cmake --preset aarch64 -B "$arm_build_dir" -DMFNS_BUILD_BENCHMARKS=ON > /dev/null
  cmake --build "$arm_build_dir" -j "$jobs" --target detect_benchmark identify_benchmark solve_benchmark
  mkdir -p "$out/aarch64"
  for b in detect_benchmark identify_benchmark solve_benchmark; do
    say "run $b under qemu-aarch64 (timings not meaningful)"
    qemu-aarch64 -L /usr/aarch64-linux-gnu "$arm_build_dir/bin/$b" --benchmark_min_time=0.01 \
      > "$out/aarch64/$b.txt" 2>&1 || echo "bench: $b failed under qemu" >&2
  done
fi
python3 benchmarks/bench_summary.py "$out" > "$out/summary.md"
say "done: $out/summary.md"
cat "$out/summary.md"
