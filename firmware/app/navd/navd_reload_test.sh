#!/usr/bin/env bash
# Issue 14 (defect 9 and item 6; host preset, ~5 s): parameter reloads on the real mfns-navd.
# navd navigates from a parameter store while frames replay; then, while it runs:
#   1. a newer blob of ANOTHER rig id lands in the store: refused, navd says why (another rig
#      id) and keeps its generation (it used to hot-load it);
#   2. a newer but corrupt blob: refused, named (it used to be skipped silently);
#   3. a newer blob of the same rig, noticed by the store watcher: taken ("parameters reloaded");
#   4. SIGHUP through the pid file: navd reloads on the signal and says what it did (nothing
#      newer; then a newer blob taken).
# The frames are 64 x 48 dark images of a shrunk paper rig (written by one `split` per camera),
# replayed in real time at 100 Hz (--realtime) for at most 60 s; SIGTERM once the checks end.
# Usage: navd_reload_test.sh MFNS_CALIB MFNS_NAVD WORK_DIR
set -euo pipefail
calib=$1 navd=$2 work=$3
fail() { echo "FAIL: $*" >&2; [[ -f $work/navd.err ]] && cat "$work/navd.err" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work/store" "$work/replay/frames"

# A paper rig with 64 x 48 cameras (same beacons), and the same rig under another id.
"$calib" paper-rig --out "$work/full.yaml" 2>/dev/null
sed -e 's/^    width: 1280$/    width: 64/' -e 's/^    height: 1024$/    height: 48/' \
    -e 's/^    intrinsics: \[.*\]$/    intrinsics: [80, 80, 0, 31.5, 23.5]/' "$work/full.yaml" >"$work/rig.yaml"
sed -e 's/^rig_id: .*/rig_id: another-flyer/' "$work/rig.yaml" >"$work/other.yaml"
"$calib" blob "$work/rig.yaml" --generation 100 --out "$work/g100.bin" 2>/dev/null
"$calib" blob "$work/other.yaml" --generation 200 --out "$work/other200.bin" 2>/dev/null
"$calib" blob "$work/rig.yaml" --generation 300 --out "$work/g300.bin" 2>/dev/null
"$calib" blob "$work/rig.yaml" --generation 400 --out "$work/g400.bin" 2>/dev/null
cp "$work/g100.bin" "$work/store/slot-a.bin"

# 6000 frame sets of dark 64 x 48 frames, one split per camera, timed by --rate-hz.
sets=6000
{ printf 'P5\n64 48\n255\n'; head -c 3072 /dev/zero; } >"$work/frame.pgm"
size=$(stat -c %s "$work/frame.pgm")
cp "$work/frame.pgm" "$work/frames.bin"  # doubled until it holds >= sets frames
while (($(stat -c %s "$work/frames.bin") < size * sets)); do
  cat "$work/frames.bin" "$work/frames.bin" >"$work/frames.tmp" && mv "$work/frames.tmp" "$work/frames.bin"
done
for cam in x y z; do
  mkdir -p "$work/replay/frames/$cam"
  head -c $((size * sets)) "$work/frames.bin" | split -b "$size" -d -a 6 --additional-suffix=.pgm - "$work/replay/frames/$cam/"
done
rm "$work/frames.bin"
[[ -f $work/replay/frames/z/005999.pgm ]] || fail "frames not written"

# Replaces a slot the way mfns-paramctl does: a temp name, then rename.
put() { cp "$1" "$work/store/$2.tmp" && mv "$work/store/$2.tmp" "$work/store/$2"; }
# Waits (up to 20 s) for a line of navd's stderr matching the pattern.
await() {
  for _ in $(seq 200); do
    grep -q -- "$1" "$work/navd.err" && return 0
    kill -0 "$pid" 2>/dev/null || fail "navd ended before: $1"
    sleep 0.1
  done
  fail "navd never said: $1"
}

"$navd" --params "$work/store" --source "replay:$work/replay" --rate-hz 100 --realtime --pid-file "$work/navd.pid" --quiet \
  2>"$work/navd.err" &
pid=$!
trap 'kill "$pid" 2>/dev/null || true' EXIT
await "parameters generation 100"

put "$work/other200.bin" slot-b.bin  # 1.
await "reload: nothing newer to take (.*slot-b.bin: blob is for another rig id.*); generation 100 stays"

head -c 100 "$work/g300.bin" >"$work/cut.bin"  # 2. a truncated, newer blob
put "$work/cut.bin" slot-b.bin
await "reload: nothing newer to take (.*slot-b.bin: .*); generation 100 stays"
grep -q "parameters reloaded" "$work/navd.err" && fail "a refused blob was taken"

put "$work/g300.bin" slot-b.bin  # 3.
await "parameters reloaded: generation 300"

# 4. SIGHUP (what mfns-paramctl sends) with nothing new: navd reloads at once and says so.
kill -HUP "$(cat "$work/navd.pid")"
await "reload: nothing newer to take (.*); generation 300 stays"
put "$work/g400.bin" slot-a.bin
kill -HUP "$(cat "$work/navd.pid")"
await "parameters reloaded: generation 400"

kill -TERM "$pid"
wait "$pid" || fail "navd exit $? after SIGTERM"
trap - EXIT
grep -q "another-flyer" "$work/navd.err" && fail "navd named the other rig as taken"
echo PASS
