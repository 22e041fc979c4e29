#!/usr/bin/env bash
# Issue 17 item 2 (host preset, ~15 s; the first run also installs node-mavlink from npm):
# mfns-navd's --output mavlink+udp:// read by an independent decoder, node-mavlink (pinned
# below, installed into the build tree's node_modules once and reused). The paper turntable
# sweep rendered from 238 deg in 2 deg steps at 5 Hz (50 frame sets, 9.8 s of sample time):
# navd starts at the first pose (--initial-pose, truth's frame set 0), keeps a fix while >= 3
# beacons are in view, is lost through the gap of the sweep (254-294 deg: <= 2 beacons) and
# acquires again after it, so the stream has a first track, a lost stretch (no ODOMETRY,
# HEARTBEAT CRITICAL) and a second track (reset_counter 1). navd sends MAVLink and the MFNS
# datagrams at once; check_mavlink.cjs checks both against the poses CSV.
#
# Without the registry the test fails, saying so; MFNS_SKIP_NPM_TESTS=1 in the environment
# turns that into a skip (exit 77) when node-mavlink is not installed yet.
# Usage: navd_mavlink_test.sh MFNS_SIM MFNS_CALIB MFNS_NAVD WORK_DIR NODE_PREFIX
set -euo pipefail
sim=$1 calib=$2 navd=$3 work=$4 prefix=$5
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
node_mavlink=2.3.0
mappings=1.0.21-20250824-1  # node-mavlink 2.3.0's dependency, pinned too: its CRC_EXTRA table

command -v node >/dev/null || fail "node not found (scripts/install-deps.sh installs nodejs and npm)"
have=$(node -p "require('$prefix/node_modules/node-mavlink/package.json').version" 2>/dev/null || true)
have_mappings=$(node -p "require('$prefix/node_modules/mavlink-mappings/package.json').version" 2>/dev/null || true)
if [[ $have != "$node_mavlink" || $have_mappings != "$mappings" ]]; then
  if [[ ${MFNS_SKIP_NPM_TESTS:-0} == 1 ]]; then
    echo "SKIP: node-mavlink $node_mavlink not installed in $prefix and MFNS_SKIP_NPM_TESTS=1"
    exit 77
  fi
  command -v npm >/dev/null || fail "npm not found (scripts/install-deps.sh installs it)"
  mkdir -p "$prefix"
  npm install --prefix "$prefix" --no-save --no-package-lock --no-audit --no-fund --loglevel=error \
    --fetch-retries=2 --fetch-retry-maxtimeout=10000 --fetch-timeout=60000 \
    "node-mavlink@$node_mavlink" "mavlink-mappings@$mappings" ||
    fail "npm could not install node-mavlink@$node_mavlink from the registry (offline? MFNS_SKIP_NPM_TESTS=1 skips this test)"
fi

rm -rf "$work"
mkdir -p "$work"
"$sim" preset paper-turntable |
  sed -e 's/^frame_rate_hz: .*/frame_rate_hz: 5/' -e 's/^frames: .*/frames: 50/' \
      -e 's/main_start_deg: .*/main_start_deg: 238/' -e 's/main_step_deg: .*/main_step_deg: 2/' >"$work/scenario.yaml"
grep -q '^frame_rate_hz: 5$' "$work/scenario.yaml" && grep -q 'main_step_deg: 2$' "$work/scenario.yaml" ||
  fail "could not make the scenario from the paper-turntable preset"
"$sim" render --scenario "$work/scenario.yaml" --out "$work/render" >"$work/render.log" 2>&1 ||
  { cat "$work/render.log"; fail "mfns-sim render"; }
"$calib" blob "$work/render/rig.yaml" --out "$work/true.bin" >/dev/null 2>&1 || fail "mfns-calib blob"
start=$(awk -F, 'NR == 2 {printf "%.4f,%.4f,%.4f,%.6f,%.6f,%.6f", $3, $4, $5, $6, $7, $8}' "$work/render/truth.csv")

# A bad --output is refused in one line naming the option, exit 1: an unknown scheme (options)
# and a host that does not resolve (at start, after the parameters).
for bad in tcp://127.0.0.1:14540 mavlink://127.0.0.1:14540 mavlink+udp://no.such.host.invalid:14540; do
  rc=0
  err=$("$navd" --params "$work/true.bin" --source "replay:$work/render" --output "$bad" --pid-file "" --quiet \
        --frames 1 2>&1) || rc=$?
  [[ $rc == 1 && $(printf '%s\n' "$err" | grep -c .) -le 2 && $err == *"--output"*"$bad"* ]] ||
    fail "--output $bad: exit $rc, expected 1 and a line naming --output: $err"
done

NODE_PATH="$prefix/node_modules" node "$here/check_mavlink.cjs" "$work/poses.csv" -- \
  "$navd" --params "$work/true.bin" --source "replay:$work/render" --rate-hz 5 --initial-pose "$start" \
  --output 'mavlink+udp://127.0.0.1:{MAV_PORT}' --output 'udp://127.0.0.1:{MFNS_PORT}' \
  --log "$work/poses.csv" --pid-file "" --quiet
# The stream must have shown what it is there to show: two tracks with a lost stretch between.
awk -F, 'NR > 1 {s = s substr($3, 1, 1)} END {exit !(s ~ /^[fd]+l+[fd]+$/)}' "$work/poses.csv" ||
  fail "the run is not fix..., lost..., fix... (the sweep or the navigator changed): $(cut -d, -f3 "$work/poses.csv" | tr '\n' ' ')"
