#!/usr/bin/env bash
# The flyer's software on a real Linux kernel (issue 19, docs/board.md): boots Debian 12's own
# arm64 kernel on QEMU's emulated `virt` board (Cortex-A72, TCG, no network) with an initramfs
# made here from Debian arm64 packages: busybox-static, the vivid test driver and the modules it
# needs, the arm64 libraries mfns-navd links, and the project's arm64 .deb, installed in the
# guest with dpkg (busybox's applet), and the arm64 gtest executables whose FIFO and flock cases
# hang under qemu-user (excluded from the aarch64 test preset). The checks
# (scripts/board/checks.sh) run on the board and report over the serial console; this script
# prints one "board: N passed, M failed" line and exits non-zero on any failure or a timeout.
#
# Usage: scripts/test-board.sh            (after scripts/install-deps.sh)
#        scripts/test-board.sh --icount   instead of the checks: instructions per frame set of a
#                                          replay on the board (-icount shift=0, one CPU), for
#                                          docs/benchmarks.md; not part of CI
# Environment:
#   MFNS_BOARD_TIMEOUT  seconds for the whole guest run (default 420)
#   MFNS_BOARD_FRAMES   frame sets mfns-navd runs (default 10)
#   MFNS_BOARD_LOOP_FRAMES frame sets navd runs on the rendered frames looped through vivid (10)
#   MFNS_BOARD_SWEEP_FRAMES frame sets of the moving sweep fed through the loopback (30)
#   MFNS_BOARD_SWEEP_PERIOD_MS its frame period: the render's and the board's captures' (100;
#                       50..100)
#   MFNS_BOARD_DISCONNECT_FRAMES frame sets of the disconnect run (default 40; camera 1 goes at
#                       ~10, is set aside 3 frame sets later and retried every 10)
#   MFNS_BOARD_SMP      guest CPUs (default 2)
#   MFNS_BOARD_NAVD_ARGS extra mfns-navd arguments (e.g. --y16)
#   MFNS_BOARD_VIVID_PARAMS vivid's module parameters instead of the rig's (docs/board.md)
#   MFNS_BOARD_HOST_BIN where the host's mfns-calib and mfns-sim are (default build/host/bin,
#                       built with the host preset when missing)
#   MFNS_BOARD_EXTRA    a folder copied to /board/extra in the guest; its run.sh runs before navd
#   MFNS_BOARD_GTEST_TIMEOUT seconds each test executable may run on the board (default 60)
#   MFNS_BOARD_KERNEL   kernel package (default: what linux-image-arm64:arm64 depends on)
# Downloads are cached in build/board-cache/; the initramfs and logs go to build/board/.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
cache=$root/build/board-cache
work=$root/build/board
timeout_s=${MFNS_BOARD_TIMEOUT:-420}
frames=${MFNS_BOARD_FRAMES:-10}
loop_frames=${MFNS_BOARD_LOOP_FRAMES:-10}   # frame sets navd runs on the looped rendered frames
render_frames=40
sweep_frames=${MFNS_BOARD_SWEEP_FRAMES:-30}          # the moving sweep through the loopback
sweep_period_ms=${MFNS_BOARD_SWEEP_PERIOD_MS:-100}   # its frame period on the board and in the render
disconnect_frames=${MFNS_BOARD_DISCONNECT_FRAMES:-40}
smp=${MFNS_BOARD_SMP:-2}
# The test executables holding the cases the aarch64 preset excludes (its filter
# "AFifo|ConcurrentInstall": threads blocked around FIFOs and flock under qemu-user); on the
# board's kernel they run natively, each with this filter and a timeout of its own.
gtest_bins=(param_loader_test param_store_test paramctl_test replay_source_test)
gtest_filter='*AFifo*:*ConcurrentInstall*'
gtest_timeout=${MFNS_BOARD_GTEST_TIMEOUT:-60}
trigger_line=0   # PL061 line 3 is the virt board's power button (gpio-keys); 0 is free
width=1280 height=1024  # config/paper-rig.yaml's cameras
# vivid: three instances, each a video capture node /dev/video0..2 (the rig's cameras in order)
# with one HDMI input (progressive; any size through the scaler) and a video output node
# /dev/video3..5 with one HDMI output (for the loopback), single-planar. docs/board.md says why.
vivid_params=${MFNS_BOARD_VIVID_PARAMS:-"n_devs=3 node_types=0x101,0x101,0x101 vid_cap_nr=0,1,2 vid_out_nr=3,4,5 num_inputs=1,1,1 input_types=0x3,0x3,0x3 num_outputs=1,1,1 output_types=0x1,0x1,0x1 multiplanar=1,1,1 ccs_cap_mode=4,4,4 ccs_out_mode=0,0,0"}
start=$(date +%s)
icount=0
[ "${1:-}" = --icount ] && icount=1

die() { echo "test-board: $*" >&2; echo "board: 0 passed, 1 failed"; exit 1; }
for tool in qemu-system-aarch64 apt-get dpkg-deb depmod cpio gzip aarch64-linux-gnu-readelf aarch64-linux-gnu-gcc aarch64-linux-gnu-strip cmake; do
  command -v "$tool" >/dev/null || die "$tool not found (run scripts/install-deps.sh)"
done

# --- 1. The flyer's software: the arm64 .deb and a parameter blob of the paper rig.
echo "test-board: building mfns-navd, mfns-paramctl, ${gtest_bins[*]} (aarch64) and the .deb" >&2
[ -f build/aarch64/CMakeCache.txt ] || cmake --preset aarch64 >/dev/null
cmake --build --preset aarch64 -j "$(nproc)" --target mfns-navd mfns-paramctl "${gtest_bins[@]}" >/dev/null
rm -rf "$work"
mkdir -p "$work/pkg" "$cache"
(cd build/aarch64 && cpack --config CPackConfig.cmake -B "$work/pkg" >/dev/null)
deb=$(ls "$work"/pkg/mfns_*_arm64.deb)
host_bin=${MFNS_BOARD_HOST_BIN:-build/host/bin}
calib=$host_bin/mfns-calib
if [ ! -x "$calib" ]; then
  echo "test-board: building mfns-calib (host) for the parameter blob" >&2
  [ -f build/host/CMakeCache.txt ] || cmake --preset host >/dev/null
  cmake --build --preset host -j "$(nproc)" --target mfns-calib >/dev/null
fi
"$calib" blob config/paper-rig.yaml --out "$work/params.bin" --generation 1 >/dev/null

# Rendered frames for vivid's loopback: the paper turntable sweep (mfns-sim render); the first
# frame set with the most beacons in view among the first $render_frames is fed to the board's
# vivid outputs, and replayed here by the same arm64 mfns-navd under qemu-aarch64, both from the
# truth pose (--initial-pose), for the poses to compare.
sim=$host_bin/mfns-sim
if [ ! -x "$sim" ]; then
  echo "test-board: building mfns-sim (host) for the rendered frames" >&2
  [ -f build/host/CMakeCache.txt ] || cmake --preset host >/dev/null
  cmake --build --preset host -j "$(nproc)" --target mfns-sim >/dev/null
fi
"$sim" render --preset paper-turntable --out "$work/sim" --frames "$render_frames" --no-images >"$work/render.log" 2>&1 ||
  die "mfns-sim render failed: $(tail -n 1 "$work/render.log")"
loop_frame=$(awk -F, 'NR > 1 { c[$1 + 0]++ } END { for (f in c) if (c[f] > best || (c[f] == best && f + 0 < first)) { best = c[f]; first = f + 0 }; print first }' "$work/sim/blobs.csv")
"$sim" render --preset paper-turntable --out "$work/sim" --frames $((loop_frame + 1)) >"$work/render.log" 2>&1 ||
  die "mfns-sim render failed: $(tail -n 1 "$work/render.log")"
mkdir -p "$work/loop/frames"
for c in $(ls "$work/sim/frames"); do
  mkdir -p "$work/loop/frames/$c"
  cp "$work/sim/frames/$c/$(printf '%06d' "$loop_frame").pgm" "$work/loop/frames/$c/000000.pgm"
done
awk -F, -v f="$loop_frame" 'BEGIN { OFS = "," } NR == 1 { print; next } $1 + 0 == f { $1 = 0; print }' "$work/sim/truth.csv" >"$work/loop/truth.csv"
loop_pose=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
  { print $col["x_mm"] "," $col["y_mm"] "," $col["z_mm"] "," $col["roll_deg"] "," $col["pitch_deg"] "," $col["yaw_deg"] }' "$work/loop/truth.csv")
"$calib" blob "$work/sim/rig.yaml" --out "$work/loop.bin" --generation 1 >/dev/null
qemu-aarch64 -L /usr/aarch64-linux-gnu build/aarch64/bin/mfns-navd --params "$work/loop.bin" --source "replay:$work/loop" \
  --initial-pose "$loop_pose" --log "$work/replay.csv" --pid-file '' --quiet 2>"$work/replay.err" ||
  die "the replay of the loop frame set failed: $(cat "$work/replay.err")"

# The moving sweep for the loopback: the paper turntable sweep rendered at the board's capture
# rate (frame_rate_hz = 1000 / $sweep_period_ms), so that the driver's stamps, one capture period
# apart, carry the sweep's motion. The board's poses are compared after the boot with a replay
# of these frames stamped with the board's own frame-set stamps (below).
[ "$sweep_period_ms" -ge 50 ] && [ "$sweep_period_ms" -le 100 ] || die "MFNS_BOARD_SWEEP_PERIOD_MS: 50..100, got $sweep_period_ms"
"$sim" preset paper-turntable | awk -v hz="$(awk -v p="$sweep_period_ms" 'BEGIN { printf "%.9g", 1000 / p }')" \
  '/^frame_rate_hz:/ { print "frame_rate_hz: " hz; next } { print }' >"$work/sweep.yaml"
grep -q "^frame_rate_hz: " "$work/sweep.yaml" || die "the paper-turntable preset has no frame_rate_hz line"
"$sim" render --scenario "$work/sweep.yaml" --out "$work/sweep" --frames "$sweep_frames" >"$work/render.log" 2>&1 ||
  die "mfns-sim render of the sweep failed: $(tail -n 1 "$work/render.log")"
"$calib" blob "$work/sweep/rig.yaml" --out "$work/sweep.bin" --generation 1 >/dev/null
sweep_pose=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next } NR == 2 {
  print $col["x_mm"] "," $col["y_mm"] "," $col["z_mm"] "," $col["roll_deg"] "," $col["pitch_deg"] "," $col["yaw_deg"] }' "$work/sweep/truth.csv")
sweep_navd_args=(--initial-pose "$sweep_pose" --deadline-ms "$sweep_period_ms" --pid-file '' --quiet)

# --- 2. Debian's arm64 kernel and busybox-static, fetched once into the cache.
kpkg=${MFNS_BOARD_KERNEL:-$(apt-cache depends linux-image-arm64:arm64 2>/dev/null |
  sed -n 's/^ *Depends: \(linux-image-[0-9.]*-[0-9]*-arm64\)\(:arm64\)\?$/\1/p' | sed -n 1p)}
if [ -z "$kpkg" ]; then  # no apt lists: take the newest kernel already in the cache
  kpkg=$(ls "$cache" 2>/dev/null | sed -n 's/^\(linux-image-[0-9.]*-[0-9]*-arm64\)_.*_arm64\.deb$/\1/p' | sort -V | tail -n 1)
fi
[ -n "$kpkg" ] || die "cannot tell which linux-image-*-arm64 bookworm has (apt-get update?)"
fetch() {  # PACKAGE: its arm64 .deb in the cache (downloaded when missing)
  local f
  f=$(ls "$cache/$1"_*_arm64.deb 2>/dev/null | sed -n 1p || true)
  if [ -z "$f" ]; then
    echo "test-board: downloading $1:arm64" >&2
    (cd "$cache" && apt-get download -q "$1:arm64" >/dev/null 2>&1) || die "apt-get download $1:arm64 failed"
    f=$(ls "$cache/$1"_*_arm64.deb | sed -n 1p)
  fi
  echo "$f"
}
kdeb=$(fetch "$kpkg")
bbdeb=$(fetch busybox-static)
kver=${kpkg#linux-image-}

# The kernel image and the modules vivid needs, kept unpacked in the cache (the whole package
# unpacks to 350 MB; only these stay).
kdir=$cache/kernel-$kver
if [ ! -f "$kdir/stamp" ]; then
  echo "test-board: unpacking $(basename "$kdeb")" >&2
  rm -rf "$kdir" "$work/kx"
  dpkg-deb -x "$kdeb" "$work/kx"
  depmod -b "$work/kx" "$kver"
  mdir=lib/modules/$kver
  mods=$(sed -n "s#^\(kernel/drivers/media/test-drivers/vivid/vivid.ko\):\(.*\)#\1 \2#p" "$work/kx/$mdir/modules.dep")
  [ -n "$mods" ] || die "vivid.ko not in $kpkg"
  mkdir -p "$kdir/$mdir"
  for m in $mods; do
    mkdir -p "$kdir/$mdir/$(dirname "$m")"
    cp "$work/kx/$mdir/$m" "$kdir/$mdir/$m"
  done
  cp "$work/kx/$mdir/modules.order" "$work/kx/$mdir/modules.builtin" "$work/kx/$mdir/modules.builtin.modinfo" "$kdir/$mdir/"
  depmod -b "$kdir" "$kver"
  cp "$work/kx/boot/vmlinuz-$kver" "$work/kx/boot/config-$kver" "$kdir/"
  rm -rf "$work/kx"
  touch "$kdir/stamp"
fi

# --- 3. The initramfs.
rootfs=$work/rootfs
mkdir -p "$rootfs"/{bin,sbin,lib,usr/bin,usr/sbin,etc,board,var/lib/dpkg/info,var/lib/dpkg/updates}
dpkg-deb -x "$bbdeb" "$work/bb"
cp "$work/bb/bin/busybox" "$rootfs/bin/busybox"
rm -rf "$work/bb"
cp -a "$kdir/lib/modules" "$rootfs/lib/"
# The arm64 shared libraries mfns-navd, mfns-paramctl and the test executables need (NEEDED,
# recursively), from Debian's arm64 packages installed on this machine (libc6, libstdc++6,
# libgcc-s1, libgpiod2).
libdirs=(/lib/aarch64-linux-gnu /usr/lib/aarch64-linux-gnu)
mkdir -p "$rootfs/lib/aarch64-linux-gnu"
declare -A seen=()
queue=("$root/build/aarch64/bin/mfns-navd" "$root/build/aarch64/bin/mfns-paramctl")
for t in "${gtest_bins[@]}"; do queue+=("$root/build/aarch64/tests/$t"); done
owners=()
while [ ${#queue[@]} -gt 0 ]; do
  f=${queue[0]}
  queue=("${queue[@]:1}")
  for lib in $(aarch64-linux-gnu-readelf -d "$f" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    [ -n "${seen[$lib]:-}" ] && continue
    seen[$lib]=1
    path=""
    for d in "${libdirs[@]}"; do [ -e "$d/$lib" ] && { path=$d/$lib; break; }; done
    [ -n "$path" ] || die "arm64 library $lib not found (install-deps.sh installs libgpiod2:arm64, libstdc++6:arm64)"
    cp -L "$path" "$rootfs/lib/aarch64-linux-gnu/$lib"
    for cand in "$path" "${path#/usr}" "/usr$path" "$(readlink -f "$path")"; do  # usrmerge: either name
      o=$(dpkg -S "$cand" 2>/dev/null | cut -d: -f1-2 | sed -n 1p || true)
      [ -n "$o" ] && { owners+=("$o"); break; }
    done
    queue+=("$path")
  done
done
interp=$(aarch64-linux-gnu-readelf -l "$root/build/aarch64/bin/mfns-navd" | sed -n 's/.*interpreter: \(.*\)\]/\1/p')
cp -L "/usr/lib/aarch64-linux-gnu/$(basename "$interp")" "$rootfs/lib/aarch64-linux-gnu/"
ln -sf "aarch64-linux-gnu/$(basename "$interp")" "$rootfs$interp"
# dpkg's database: the library packages whose files were copied in, at the host's versions, so
# that the .deb's Depends are met the way they are on a Debian board.
for p in $(printf '%s\n' "${owners[@]}" libc6:arm64 | grep . | sort -u); do
  v=$(dpkg-query -W -f='${Version}' "$p")
  printf 'Package: %s\nStatus: install ok installed\nArchitecture: arm64\nVersion: %s\n\n' "${p%:arm64}" "$v" >>"$rootfs/var/lib/dpkg/status"
done
cp "$deb" "$rootfs/board/mfns.deb"
cp "$work/params.bin" "$rootfs/board/params.bin"
cp scripts/board/checks.sh "$rootfs/board/checks.sh"
# The test executables without their symbols: 3.2-3.7 MB each with -g1, 0.5-0.6 MB stripped
# (the initramfs grows by about 1 MB); gtest's failure messages still name file and line.
mkdir -p "$rootfs/board/tests"
for t in "${gtest_bins[@]}"; do
  aarch64-linux-gnu-strip -o "$rootfs/board/tests/$t" "build/aarch64/tests/$t"
done
cp "$work/loop.bin" "$rootfs/board/loop.bin"
cp -r "$work/loop/frames" "$rootfs/board/loop"
if [ "$icount" -eq 0 ]; then  # the sweep's 90 frames: 33 of the initramfs' 40 MB
  cp "$work/sweep.bin" "$rootfs/board/sweep.bin"
  cp -r "$work/sweep/frames" "$rootfs/board/sweep"
fi
if [ "$icount" -eq 1 ]; then  # the rendered frame sets 0..$loop_frame, replayed on the board
  mkdir -p "$rootfs/board/replay"
  cp -r "$work/sim/frames" "$work/sim/truth.csv" "$rootfs/board/replay/"
fi
cp scripts/board/init "$rootfs/init"
# board-ctl sets V4L2 controls by name (vivid's test pattern, Disconnect), board-loop streams
# frames through vivid's loopback: no v4l2-ctl on the board.
for tool in board-ctl board-loop board-now; do
  aarch64-linux-gnu-gcc -static -O2 -Wall -Werror -o "$rootfs/usr/bin/$tool" "scripts/board/$tool.c"
done
# A folder of extra files for the guest (a probe while debugging): run.sh in it runs before navd.
[ -z "${MFNS_BOARD_EXTRA:-}" ] || cp -r "$MFNS_BOARD_EXTRA" "$rootfs/board/extra"
chmod 0755 "$rootfs/init"
cat >"$rootfs/board/board.env" <<EOF
VIVID_PARAMS="$vivid_params"
NUM_CAMERAS=3
WIDTH=$width
HEIGHT=$height
FRAMES=$frames
TRIGGER_LINE=$trigger_line
DISCONNECT_CAMERA=1
DISCONNECT_AT=10
DISCONNECT_FRAMES=$disconnect_frames
LOOP_FRAMES=$loop_frames
LOOP_POSE=$loop_pose
SWEEP_FRAMES=$sweep_frames
SWEEP_PERIOD_MS=$sweep_period_ms
SWEEP_POSE=$sweep_pose
ICOUNT=$icount
REPLAY_FRAMES=$((loop_frame + 1))
REPLAY_POSE=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next } NR == 2 {
  print $col["x_mm"] "," $col["y_mm"] "," $col["z_mm"] "," $col["roll_deg"] "," $col["pitch_deg"] "," $col["yaw_deg"] }' "$work/sim/truth.csv")
LOOP_CAMERAS="$(sed -n 's/^  - name: *//p' "$work/sim/rig.yaml" | tr '\n' ' ')"
NAVD_EXTRA="${MFNS_BOARD_NAVD_ARGS:-}"
GTEST_BINS="${gtest_bins[*]}"
GTEST_FILTER='$gtest_filter'
GTEST_TIMEOUT=$gtest_timeout
EOF
(cd "$rootfs" && find . | LC_ALL=C sort | cpio -o -H newc --quiet -R 0:0 | gzip -1 >"$work/initramfs.gz")
rm -rf "$rootfs"
echo "test-board: initramfs $(du -k "$work/initramfs.gz" | cut -f1) KiB, kernel $kpkg; booting (timeout ${timeout_s} s)" >&2

# --- 4. Boot. The console is the serial port (stdout -> console.log); PL061 writes are traced
# on the host (QEMU's pl061_set_output events) to count the trigger pulses.
boot=$(date +%s)
status=0
accel=(-smp "$smp")
[ "$icount" -eq 1 ] && accel=(-smp 1 -icount shift=0,sleep=off)  # 1 ns of guest time per instruction
timeout --kill-after=10 "$timeout_s" qemu-system-aarch64 -M virt -cpu cortex-a72 "${accel[@]}" -m 1024 \
  -nographic -no-reboot -net none \
  -kernel "$kdir/vmlinuz-$kver" -initrd "$work/initramfs.gz" \
  -append "console=ttyAMA0 panic=-1 quiet loglevel=3 log_buf_len=16M" \
  -trace "pl061_set_output,file=$work/pl061.trace" \
  </dev/null >"$work/console.log" 2>"$work/qemu.err" || status=$?
end=$(date +%s)
# The console without carriage returns, read from a file: `tr | grep -q` under pipefail fails
# whenever grep exits before tr has written everything (SIGPIPE), and a check went missing.
tr -d '\r' <"$work/console.log" >"$work/console.txt"
console=$work/console.txt
grep -aE '^BOARD ' "$console" | sed 's/^BOARD /board: /' >&2 || true

if [ "$icount" -eq 1 ]; then
  line=$(grep -a '^BOARD ICOUNT ' "$console" | sed 's/^BOARD ICOUNT //' || true)
  if [ -z "$line" ]; then
    echo "test-board: --icount: no measurement came back (qemu exit $status; console: $work/console.log)" >&2
    exit 1
  fi
  echo "board icount: $line (host: $(grep -c . "$work/sim/truth.csv" | awk '{print $1 - 1}') frame sets rendered)"
  exit 0
fi
passed=$(grep -ac '^BOARD PASS ' "$console" || true)
failed=$(grep -ac '^BOARD FAIL ' "$console" || true)
if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
  echo "test-board: FAIL: the guest did not finish within ${timeout_s} s (console: $work/console.log)" >&2
  failed=$((failed + 1))
elif ! grep -aq '^BOARD CHECKS COMPLETE' "$console"; then
  echo "test-board: FAIL: the checks stopped before their end (qemu exit $status; console: $work/console.log):" >&2
  grep -av '^BOARD ' "$console" | tail -n 20 >&2 || true
  failed=$((failed + 1))
fi
# The trigger on the emulated PL061: one rising edge (level 1) per frame set on the line, in the
# two navd runs given --trigger (the checks' run and the disconnect run).
if grep -aq '^BOARD PASS gpiochip' "$console"; then
  edges=$(grep -c "pl061_set_output .* setting output $trigger_line to 1\$" "$work/pl061.trace" 2>/dev/null || true)
  expected=$((frames + disconnect_frames))
  if [ "$edges" -eq "$expected" ]; then
    echo "board: PASS gpio-pulses: $edges rising edges on PL061 line $trigger_line for $frames + $disconnect_frames frame sets (QEMU trace)" >&2
    passed=$((passed + 1))
  else
    echo "board: FAIL gpio-pulses: $edges rising edges on PL061 line $trigger_line, expected $frames + $disconnect_frames (QEMU trace $work/pl061.trace)" >&2
    failed=$((failed + 1))
  fi
fi
verdict() {  # NAME "ok|bad DETAIL" CONTEXT FILES: a counted PASS or FAIL line (FILES named on failure)
  if [ "${2%% *}" = ok ]; then
    echo "board: PASS $1: ${2#ok } ($3)" >&2
    passed=$((passed + 1))
  else
    echo "board: FAIL $1: ${2#bad } ($3; $4)" >&2
    failed=$((failed + 1))
  fi
}
# navd on the looped rendered frames against the replay of the same frame set: every frame set
# a fix, each pose equal to the replay's within the CSV's printed precision (0.0001 mm, 1e-6 deg)
# plus numerical noise (0.001 mm, 1e-5 deg).
sed -n 's/^BOARD POSE //p' "$console" >"$work/loop-poses.csv"
if [ ! -s "$work/loop-poses.csv" ]; then
  echo "board: FAIL loop-poses: no poses from the looped frames came back (console: $work/console.log)" >&2
  failed=$((failed + 1))
else
  r=$(awk -F, -v n="$loop_frames" '
    NR == FNR { if (FNR == 1) { for (i = 1; i <= NF; ++i) rc[$i] = i; next }
                rs = $rc["status"]; for (j = 0; j < 6; ++j) rv[j] = $(rc["x_mm"] + j); next }
    FNR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i; next }
    { rows++; if ($c["status"] == "fix") fix++
      for (j = 0; j < 6; ++j) { d = $(c["x_mm"] + j) - rv[j]; if (d < 0) d = -d; tol = j < 3 ? 0.001 : 0.00001; if (d > tol) off++; if (d > worst[j]) worst[j] = d } }
    END { ok = rs == "fix" && rows == n && fix == n && off == 0
          printf "%s %d of %d frame sets fixed (replay: %s); largest differences from the replay %.4f %.4f %.4f mm, %.6f %.6f %.6f deg\n", ok ? "ok" : "bad", fix, rows, rs, worst[0], worst[1], worst[2], worst[3], worst[4], worst[5] }' \
    "$work/replay.csv" "$work/loop-poses.csv")
  verdict loop-poses "$r" "frame set $loop_frame of paper-turntable" "$work/loop-poses.csv vs $work/replay.csv"
fi
# navd on the sweep through the loopback against the arm64 replay of the same frames (qemu-user):
# the frames each camera captured, in order, each frame set stamped as the board's navd stamped
# it (the earliest of its three captures): the same input to the tracker, so the same fix count
# and each pose equal within the tolerance above. A second replay with the render's own stamps (exactly one period apart) is reported
# beside it: how much the board's capture jitter changed.
sed -n 's/^BOARD SWEEP //p' "$console" >"$work/sweep-poses.csv"
sweep_rows=$(awk 'NR > 1' "$work/sweep-poses.csv" | grep -c . || true)
if [ "$sweep_rows" -ne "$sweep_frames" ]; then
  echo "board: FAIL sweep-poses: $sweep_rows of $sweep_frames frame sets' poses came back from the board (console: $work/console.log)" >&2
  failed=$((failed + 1))
else
  # The frames as navd got them: navd dequeues every capture in order (a capture with no
  # buffer free is dropped by the driver and seen by no one), so its n-th frame of camera k is
  # camera k's n-th capture. Normally frame set n; a frame set captured twice (the feeder late,
  # the board stalled) is replayed twice. Checked against navd's own stamps: its frame-set
  # stamp is the earliest of the three captures.
  rm -rf "$work/sweep-replay"
  sed -n 's/^BOARD CAPTURE //p' "$console" | sort -k1,1n -k3,3n >"$work/sweep-captures.txt"
  cams=($(sed -n 's/^  - name: *//p' "$work/sweep/rig.yaml"))
  mapping=$(awk -v n="$sweep_frames" -v ncams="${#cams[@]}" '
    NR == FNR { if (FNR > 1) { split($0, f, ","); t[FNR - 2] = f[2] }; next }
    { k = $1; i = got[k]++; if (i < n) { set[k, i] = $4; st[k, i] = $3 } }
    END {
      bad = 0; repeats = 0
      for (k = 0; k < ncams; ++k) if (got[k] < n) { printf "bad camera %d: %d captures for %d frame sets\n", k, got[k], n; exit }
      for (i = 0; i < n; ++i) {
        m = ""
        for (k = 0; k < ncams; ++k) { if (set[k, i] < 0) bad++; if (m == "" || st[k, i] + 0 < m + 0) m = st[k, i]; if (i > 0 && set[k, i] == set[k, i - 1]) repeats++ }
        if (m != t[i]) { printf "bad frame set %d: navd stamped it %s, its earliest capture is %s\n", i, t[i], m; exit }
      }
      if (bad) { printf "bad %d captures held no frame set of the sweep\n", bad; exit }
      for (i = 0; i < n; ++i) { printf "map %d", i; for (k = 0; k < ncams; ++k) printf " %d", set[k, i]; printf " %s\n", t[i] }
      printf "ok %d repeated\n", repeats
    }' "$work/sweep-poses.csv" "$work/sweep-captures.txt")
fi
if [ "$sweep_rows" -eq "$sweep_frames" ] && [ "$(echo "$mapping" | tail -n 1 | cut -d' ' -f1)" != ok ]; then
  echo "board: FAIL sweep-poses: cannot tell which frames navd got: $(echo "$mapping" | tail -n 1 | sed 's/^bad //')" >&2
  failed=$((failed + 1))
elif [ "$sweep_rows" -eq "$sweep_frames" ]; then
  repeated=$(echo "$mapping" | tail -n 1 | cut -d' ' -f2)
  for c in "${cams[@]}"; do mkdir -p "$work/sweep-replay/frames/$c"; done
  echo "$mapping" | sed -n 's/^map //p' | while read -r i rest; do
    set -- $rest
    for c in "${cams[@]}"; do
      ln -s "$work/sweep/frames/$c/$(printf '%06d' "$1").pgm" "$work/sweep-replay/frames/$c/$(printf '%06d' "$i").pgm"
      shift
    done
  done
  echo "$mapping" | sed -n 's/^map //p' | awk -v ncams="${#cams[@]}" 'BEGIN { print "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg" }
    { printf "%d,%s,0,0,0,0,0,0\n", $1, $(ncams + 2) }' >"$work/sweep-replay/truth.csv"
  compare() {  # REPLAY.csv BOARD.csv: "ok|bad <detail>"
    awk -F, -v n="$sweep_frames" '
      NR == FNR { if (FNR == 1) { for (i = 1; i <= NF; ++i) rc[$i] = i; next }
                  r = FNR - 2; rs[r] = $rc["status"]; for (j = 0; j < 6; ++j) rv[r, j] = $(rc["x_mm"] + j); next }
      FNR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i; next }
      { r = FNR - 2; rows++; s = $c["status"]; if (s == "fix") fix++; if (rs[r] == "fix") rfix++
        if (s != rs[r]) { other++; if (first == "") first = sprintf(" (frame set %d: %s, replay %s)", r, s, rs[r]) }
        if (s == "lost" || rs[r] == "lost") next
        for (j = 0; j < 6; ++j) { d = $(c["x_mm"] + j) - rv[r, j]; if (d < 0) d = -d; tol = j < 3 ? 0.001 : 0.00001; if (d > tol) off++; if (d > worst[j]) worst[j] = d } }
      END { ok = rows == n && fix == rfix && other == 0 && off == 0
            printf "%s %d of %d frame sets fixed (replay: %d), %d with another status%s, %d poses off; largest differences %.4f %.4f %.4f mm, %.6f %.6f %.6f deg\n", ok ? "ok" : "bad", fix, rows, rfix, other, first, off, worst[0], worst[1], worst[2], worst[3], worst[4], worst[5] }' "$1" "$2"
  }
  if qemu-aarch64 -L /usr/aarch64-linux-gnu build/aarch64/bin/mfns-navd --params "$work/sweep.bin" --source "replay:$work/sweep-replay" \
      "${sweep_navd_args[@]}" --log "$work/sweep-replay.csv" 2>"$work/sweep-replay.err"; then
    r=$(compare "$work/sweep-replay.csv" "$work/sweep-poses.csv")
  else
    r="bad the replay failed: $(tail -n 1 "$work/sweep-replay.err")"
  fi
  nominal="no replay with the render's stamps"
  if qemu-aarch64 -L /usr/aarch64-linux-gnu build/aarch64/bin/mfns-navd --params "$work/sweep.bin" --source "replay:$work/sweep" \
      "${sweep_navd_args[@]}" --log "$work/sweep-nominal.csv" 2>"$work/sweep-nominal.err"; then
    nominal=$(compare "$work/sweep-nominal.csv" "$work/sweep-poses.csv")
    nominal="with the render's stamps: ${nominal#* }"
  fi
  stamps=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "t_ns") c = i; next }
    { if (NR > 2) { d = ($c - last) / 1e6; if (n == 0 || d < lo) lo = d; if (d > hi) hi = d; n++ } last = $c }
    END { printf "frame sets %.1f-%.1f ms apart", lo, hi }' "$work/sweep-poses.csv")
  verdict sweep-poses "$r" "$sweep_frames frame sets of paper-turntable at $sweep_period_ms ms; $stamps; $repeated frames repeated" \
    "$work/sweep-poses.csv vs $work/sweep-replay.csv"
  echo "board: INFO sweep-poses: $nominal" >&2
fi
[ "$passed" -gt 0 ] || failed=$((failed + 1))
echo "test-board: boot and checks $((end - boot)) s, total $((end - start)) s" >&2
echo "board: ${passed} passed, ${failed} failed"
[ "$failed" -eq 0 ]
