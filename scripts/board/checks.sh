#!/bin/sh
# The checks that run on the emulated board (scripts/test-board.sh, docs/board.md). Each prints
# one "BOARD PASS name: detail" or "BOARD FAIL name: detail" line on the serial console; the
# host counts them. Settings come from /board/board.env, written by the host script.
. /board/board.env
pass() { echo "BOARD PASS $*"; }
fail() { echo "BOARD FAIL $*"; }
info() { echo "BOARD INFO $*"; }

# 1. vivid and its dependencies (modules.dep made by depmod on the host for this subset).
if modprobe vivid $VIVID_PARAMS 2>/tmp/modprobe.err; then
  pass "vivid: modprobe vivid $VIVID_PARAMS"
else
  fail "vivid: modprobe: $(cat /tmp/modprobe.err)"
fi
n=0
while [ $n -lt 50 ] && [ ! -c /dev/video$((NUM_CAMERAS - 1)) ]; do usleep 100000; n=$((n + 1)); done
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do
  name=$(cat /sys/class/video4linux/video$k/name 2>/dev/null)
  if [ -c /dev/video$k ] && [ "$name" = "vivid-00$k-vid-cap" ]; then
    pass "video$k: /dev/video$k is $name"
  else
    fail "video$k: /dev/video$k missing or not vivid capture ('$name')"
  fi
  k=$((k + 1))
done

# 2. The project's arm64 .deb through dpkg (busybox's dpkg applet; the libraries it depends on
#    are listed as installed in /var/lib/dpkg/status by the host script, their files are in /lib).
if dpkg -i /board/mfns.deb >/tmp/dpkg.out 2>&1 && [ -x /usr/bin/mfns-navd ] && [ -x /usr/bin/mfns-paramctl ]; then
  pass "dpkg-install: $(dpkg -l mfns 2>/dev/null | grep mfns | tr -s ' ' | cut -c1-60)"
else
  fail "dpkg-install: $(tr '\n' ' ' </tmp/dpkg.out)"
fi
if mfns-paramctl install --store /var/lib/mfns/params /board/params.bin >/tmp/paramctl.out 2>&1; then
  pass "params: $(tr '\n' ' ' </tmp/paramctl.out)"
else
  fail "params: mfns-paramctl install: $(tr '\n' ' ' </tmp/paramctl.out)"
fi

# --icount: no checks, the instructions of a replay on the board instead (QEMU's -icount
# shift=0: the monotonic clock advances 1 ns per instruction). The replay of frame sets
# 0..REPLAY_FRAMES-1 from the truth pose minus the replay of frame set 0 alone, per frame set.
if [ "$ICOUNT" = 1 ]; then
  run() {  # N: instructions (ns) of a replay of N frame sets; navd's summary in /tmp/icount$1.out
    a=$(board-now)
    mfns-navd --params /board/loop.bin --source replay:/board/replay --frames "$1" --initial-pose "$REPLAY_POSE" \
      --pid-file '' --quiet $NAVD_EXTRA >/tmp/icount$1.out 2>&1
    b=$(board-now)
    echo $((b - a))
  }
  stages() {  # FILE: navd's per-stage means (ms; under -icount M instructions) as "name mean ..."
    sed -n 's/^mfns-navd: stages, ms per frame set (mean \/ worst): //p' "$1" | tr ',' '\n' | awk '{ printf "%s %s ", $1, $2 }'
  }
  one=$(run 1)
  all=$(run "$REPLAY_FRAMES")
  sed 's/^/BOARD LOG navd (icount): /' /tmp/icount$REPLAY_FRAMES.out
  # Per stage as for the whole: the replay's stage totals minus frame set 0's, per frame set.
  per_stage=$(awk -v a="$(stages /tmp/icount$REPLAY_FRAMES.out)" -v o="$(stages /tmp/icount1.out)" -v n="$REPLAY_FRAMES" 'BEGIN {
    na = split(a, A, " "); split(o, O, " ")
    for (i = 1; i < na; i += 2) printf "%s%s %.2f M", (i > 1 ? ", " : ""), A[i], (A[i + 1] * n - O[i + 1]) / (n - 1) }')
  echo "BOARD ICOUNT $(awk -v a="$all" -v o="$one" -v n="$REPLAY_FRAMES" 'BEGIN {
    printf "%.1f M instructions per frame set (replay of %d frame sets %.1f M, of 1 frame set %.1f M)", (a - o) / (n - 1) / 1e6, n, a / 1e6, o / 1e6 }'); by stage: $per_stage; $(grep 'done:' /tmp/icount$REPLAY_FRAMES.out | sed 's/^mfns-navd: //')"
  echo "BOARD CHECKS COMPLETE"
  exit 0
fi

# 3. The GPIO controller: QEMU virt's PL061 as a GPIO character device.
chip=""
for c in /sys/class/gpio/gpiochip*; do
  [ -e "$c/label" ] || continue
  label=$(cat "$c/label")
  cdev=$(ls "$c/device" 2>/dev/null | grep '^gpiochip[0-9]' | head -n 1)
  info "gpio: $label ($(cat "$c/ngpio") lines) /dev/$cdev"
  case "$label" in *pl061*) chip=$cdev ;; esac
done
if [ -n "$chip" ] && [ -c "/dev/$chip" ]; then
  pass "gpiochip: PL061 is /dev/$chip"
  trigger="--trigger $chip:$TRIGGER_LINE"
else
  fail "gpiochip: no PL061 GPIO character device"
  trigger=""
fi

[ -x /board/extra/run.sh ] && /board/extra/run.sh 2>&1 | sed 's/^/BOARD INFO extra: /'

# 4. mfns-navd on the three vivid capture devices. The V4L2 core logs what navd asks of each
#    device to the kernel log (dev_debug: 0x01 ioctls, 0x02 their arguments, 0x04 file
#    operations such as mmap, 0x08 streaming ioctls QBUF/DQBUF, 0x10 poll): the driver's side of
#    the handshake, read back with dmesg after the run.
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do echo 0x1f >/sys/class/video4linux/video$k/dev_debug; k=$((k + 1)); done
dmesg -c >/dev/null
mfns-navd --params /var/lib/mfns/params --source v4l2 --frames "$FRAMES" --log /tmp/poses.csv \
  --pid-file '' --quiet $trigger $NAVD_EXTRA >/tmp/navd.out 2>&1 &
pid=$!
maps=0
gpioline=""
t0=$(cut -d' ' -f1 /proc/uptime)
while kill -0 $pid 2>/dev/null; do
  m=$(grep -c '/dev/video' /proc/$pid/maps 2>/dev/null)
  [ -n "$m" ] && [ "$m" -gt "$maps" ] && maps=$m
  [ -z "$gpioline" ] && gpioline=$(grep 'mfns-navd' /sys/kernel/debug/gpio 2>/dev/null | tr -s ' ')
  usleep 50000
done
wait $pid
rc=$?
t1=$(cut -d' ' -f1 /proc/uptime)
dmesg -s 4194304 | tr -d '\r' >/tmp/v4l2.log
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do echo 0 >/sys/class/video4linux/video$k/dev_debug; k=$((k + 1)); done
sed 's/^/BOARD LOG navd: /' /tmp/navd.out
info "navd ran $(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.1f", b - a}') s"
done_line=$(grep 'done:' /tmp/navd.out)
if [ $rc -eq 0 ] && echo "$done_line" | grep -q "done: $FRAMES frame sets" && ! grep -q 'did not start' /tmp/navd.out; then
  pass "navd-run: exit 0, $(echo "$done_line" | sed 's/^mfns-navd: //')"
elif grep -q 'did not start' /tmp/navd.out; then
  fail "navd-run: exit $rc, $(grep -E 'did not start|: camera ' /tmp/navd.out | sed 's/^mfns-navd: //' | tr '\n' ';')"
else
  fail "navd-run: exit $rc, $(tail -n 2 /tmp/navd.out | tr '\n' ' ')"
fi
if [ "$maps" -ge $((NUM_CAMERAS * 4)) ]; then
  pass "mmap: $maps /dev/video* mappings in navd's address space (>= $NUM_CAMERAS cameras x 4 buffers)"
else
  fail "mmap: $maps /dev/video* mappings seen in navd's address space, expected >= $((NUM_CAMERAS * 4))"
fi
# Per camera, from the kernel's log of the device: S_FMT GREY at the rig size, REQBUFS MMAP,
# the buffers mmapped, STREAMON, poll called, and every DQBUF stamped CLOCK_MONOTONIC
# (V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC, 0x2000) with increasing timestamps; sequence gaps are
# frames the driver dropped while navd held its buffers (drops, not errors).
info "a DQBUF as the kernel logged it: $(grep -m 1 'video0: VIDIOC_DQBUF' /tmp/v4l2.log | sed 's/^\[[ 0-9.]*\] //')"
k=0
kernel_gaps=0
while [ $k -lt "$NUM_CAMERAS" ]; do
  r=$(awk -v dev="video$k:" -v w="$WIDTH" -v h="$HEIGHT" '
    function dec(s) { sub(/^0+/, "", s); return s == "" ? 0 : s + 0 }
    index($0, dev) == 0 { next }
    /VIDIOC_S_FMT/ {  # logged after the call: what the driver set
      fmt = index($0, "width=" w ", height=" h ",") && /pixelformat=GREY/ && /field=none/
      answer = $0; sub(/.*VIDIOC_S_FMT: /, "", answer); sub(/, bytesperline.*/, "", answer); sub(/ little-endian \(0x[0-9a-f]+\)/, "", answer)
    }
    /VIDIOC_REQBUFS/ && /memory=mmap/ { reqbufs = 1 }
    / mmap \(/ { mm++ }
    /VIDIOC_STREAMON/ { on = 1 }
    /poll: / { polls++ }
    /VIDIOC_DQBUF/ && !/error/ {
      dq++
      if (match($0, /VIDIOC_DQBUF: [0-9]+:[0-9]+:[0-9]+\.[0-9]+/)) {
        split(substr($0, RSTART + 14, RLENGTH - 14), a, /[:.]/)
        # the log prints tv_usec; busybox awk reads a leading 0 as octal, hence dec()
        t = ((dec(a[1]) * 60 + dec(a[2])) * 60 + dec(a[3])) * 1e6 + dec(a[4])
        stamp = substr($0, RSTART + 14, RLENGTH - 14)
        if (dq > 1 && t <= last) { back++; if (why == "") why = sprintf(" (DQBUF %d stamped %s after %s)", dq, stamp, last_stamp) }
        last = t; last_stamp = stamp
      }
      if (match($0, /flags=0x[0-9a-f]+/)) {
        f = substr($0, RSTART + 8, RLENGTH - 8); v = 0
        for (i = 1; i <= length(f); ++i) v = v * 16 + index("0123456789abcdef", substr(f, i, 1)) - 1
        if (int(v / 8192) % 2 != 1) notmono++   # 0x2000
      }
      if (match($0, /sequence=[0-9]+/)) {
        q = substr($0, RSTART + 9, RLENGTH - 9) + 0
        if (dq > 1 && q > lastq + 1) gaps += q - lastq - 1
        lastq = q
      }
    }
    END {
      ok = fmt && reqbufs && mm >= 4 && on && polls > 0 && dq > 0 && back + notmono == 0
      if (!fmt) printf "bad expected S_FMT to set GREY %dx%d field none, the driver set %s\n", w, h, answer == "" ? "nothing" : answer
      else printf "%s S_FMT GREY %dx%d %s, REQBUFS mmap %s, %d mmap, STREAMON %s, %d poll, %d DQBUF, %d not increasing%s, %d not monotonic, %d frames dropped by the driver (sequence gaps)\n", \
        ok ? "ok" : "bad", w, h, fmt ? "yes" : "no", reqbufs ? "yes" : "no", mm, on ? "yes" : "no", polls, dq, back, why, notmono, gaps
    }' /tmp/v4l2.log)
  g=$(echo "$r" | sed -n 's/.*, \([0-9]*\) frames dropped by the driver.*/\1/p')
  kernel_gaps=$((kernel_gaps + ${g:-0}))
  case "$r" in
    ok*) pass "v4l2-video$k: ${r#ok }" ;;
    *) fail "v4l2-video$k: ${r#bad }" ;;
  esac
  k=$((k + 1))
done
faults=$(grep 'faults:' /tmp/navd.out | sed 's/^mfns-navd: faults: //')
info "faults: ${faults:-none}"
navd_drops=$(echo "$faults" | sed -n 's/.*dropped \([0-9]*\).*/\1/p')
if [ "${navd_drops:-0}" -eq "$kernel_gaps" ]; then
  pass "drops: navd counted ${navd_drops:-0} dropped frames, the sequence gaps of the kernel's DQBUF log add up to $kernel_gaps"
else
  fail "drops: navd counted ${navd_drops:-0} dropped frames, the kernel's DQBUF sequence gaps add up to $kernel_gaps"
fi
bad=$(echo "$faults" | awk -F', ' '{for (i = 1; i <= NF; ++i) if ($i ~ /^(timeouts|driver errors|clock faults|trigger errors) [1-9]/) print $i}' | tr '\n' ' ')
if [ -z "$bad" ]; then
  pass "driver-faults: no timeouts, driver errors, clock faults or trigger errors"
else
  fail "driver-faults: $bad"
fi
# The poses CSV's t_ns is the frame set's driver timestamp (CLOCK_MONOTONIC): strictly increasing,
# and on the guest's monotonic clock (between navd's start and end in /proc/uptime's seconds).
rows=$(awk -F, 'NR > 1' /tmp/poses.csv 2>/dev/null | wc -l)
mono=$(awk -F, -v t0="$t0" -v t1="$t1" '
  NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "t_ns") c = i; next }
  { t = $c + 0; if (n > 0 && t <= last) back++; if (t / 1e9 < t0 - 1 || t / 1e9 > t1 + 1) off++; last = t; n++ }
  END { printf "%d rows, %d not increasing, %d off the monotonic clock", n, back + 0, off + 0; exit (n > 0 && back + off == 0) ? 0 : 1 }' /tmp/poses.csv)
if [ $? -eq 0 ] && [ "$rows" -eq "$FRAMES" ]; then
  pass "timestamps: $mono"
else
  fail "timestamps: $mono (expected $FRAMES rows)"
fi
awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) { if ($i == "status") s = i; if ($i == "reason") r = i }; next }
  { c[$s " " $r]++ } END { for (k in c) printf "BOARD INFO poses: %d x %s\n", c[k], k }' /tmp/poses.csv
if [ -n "$trigger" ]; then
  if [ -n "$gpioline" ]; then
    pass "gpio-claim: navd held the line:$gpioline"
  else
    fail "gpio-claim: line $TRIGGER_LINE of $chip never seen claimed by mfns-navd in /sys/kernel/debug/gpio"
  fi
fi

# 5. vivid's Disconnect control on one camera mid-run (a USB camera unplugged: every ioctl and
#    poll of its open file handles fails with ENODEV; the node comes back once its last file
#    handle is closed, as navd's retry does). A smooth image (test pattern Gray Ramp, no OSD
#    text) keeps navd's frame sets short. The kernel log shows what each device did.
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do
  board-ctl /dev/video$k 'Test Pattern' 'Gray Ramp' && board-ctl /dev/video$k 'OSD Text Mode' 'None' ||
    fail "vivid-controls: video$k"
  echo 0x0d >/sys/class/video4linux/video$k/dev_debug  # ioctls, file operations, QBUF/DQBUF
  k=$((k + 1))
done
dmesg -c >/dev/null
mfns-navd --params /var/lib/mfns/params --source v4l2 --frames "$DISCONNECT_FRAMES" --log /tmp/disconnect.csv \
  --camera-timeouts 3 --camera-retry-every 10 --pid-file '' --quiet $trigger >/tmp/navd-disconnect.out 2>&1 &
pid=$!
n=0
while kill -0 $pid 2>/dev/null && [ "$(dmesg | grep -c 'video1: VIDIOC_DQBUF$')" -lt "$DISCONNECT_AT" ] && [ $n -lt 600 ]; do
  usleep 100000
  n=$((n + 1))
done
board-ctl /dev/video$DISCONNECT_CAMERA Disconnect 1 || fail "disconnect: board-ctl Disconnect on /dev/video$DISCONNECT_CAMERA"
wait $pid
rc=$?
dmesg -s 16777216 | tr -d '\r' >/tmp/disconnect.log
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do echo 0 >/sys/class/video4linux/video$k/dev_debug; k=$((k + 1)); done
sed 's/^/BOARD LOG navd (disconnect): /' /tmp/navd-disconnect.out
r=$(awk -v lost="video$DISCONNECT_CAMERA:" -v inst="vivid-00$DISCONNECT_CAMERA: " -v n="$NUM_CAMERAS" '
  index($0, inst "disconnect") { phase = 1; next }
  index($0, inst "reconnect") { if (phase == 1) phase = 2; next }
  /VIDIOC_DQBUF$/ {
    dev = $0; sub(/^.*\] /, "", dev); sub(/ .*/, "", dev)
    if (phase == 0) before[dev]++
    else if (phase == 1) during[dev]++
    else after[dev]++
  }
  phase == 2 && index($0, lost " VIDIOC_STREAMON") { restarted = 1 }
  END {
    others = 1
    for (k = 0; k < n; ++k) { d = "video" k ":"; if (d != lost && during[d] + 0 == 0) others = 0 }
    ok = phase == 2 && others && restarted && after[lost] > 0
    printf "%s %s %d frames before the disconnect, reconnect %s, STREAMON again %s, %d frames after;", \
      ok ? "ok" : "bad", lost, before[lost], phase == 2 ? "yes" : "no", restarted ? "yes" : "no", after[lost]
    for (k = 0; k < n; ++k) { d = "video" k ":"; if (d != lost) printf " %s %d frames while it was away;", d, during[d] }
    printf "\n"
  }' /tmp/disconnect.log)
done_line=$(grep -E 'done:|faults:' /tmp/navd-disconnect.out | sed 's/^mfns-navd: //' | tr '\n' ';')
if [ $rc -eq 0 ] && echo "$done_line" | grep -q "done: $DISCONNECT_FRAMES frame sets" && [ "${r%% *}" = ok ]; then
  pass "disconnect: ${r#ok } navd: $done_line"
else
  fail "disconnect: ${r#* } navd exit $rc: $done_line"
fi

# 6. Rendered frames through vivid's loopback: each instance's HDMI output (video3..5) loops to
#    its capture (video0..2) with DV timings 1280x1024p60 on both; first a known pattern,
#    compared pixel for pixel, then one rendered frame set of the paper turntable sweep fed
#    continuously while navd runs from the truth pose; its poses go to the host (BOARD POSE)
#    to compare with the replay of the same frames.
k=0
feeders=""
while [ $k -lt "$NUM_CAMERAS" ]; do
  board-ctl /dev/video$k 'Loop Video' 1 && board-ctl /dev/video$k 'OSD Text Mode' 'None' || fail "loop-controls: video$k"
  r=$(board-loop check /dev/video$k /dev/video$((k + NUM_CAMERAS)) 2>&1)
  case "$r" in
    *pixel-exact*) pass "loopback-video$k: $r" ;;
    *) fail "loopback-video$k: $r" ;;
  esac
  cam=$(echo $LOOP_CAMERAS | cut -d' ' -f$((k + 1)))
  board-loop feed /dev/video$k /dev/video$((k + NUM_CAMERAS)) /board/loop/$cam/000000.pgm >/tmp/feed$k.out 2>&1 &
  feeders="$feeders $!"
  k=$((k + 1))
done
usleep 500000
mfns-navd --params /board/loop.bin --source v4l2 --frames "$LOOP_FRAMES" --initial-pose "$LOOP_POSE" --log /tmp/loop.csv \
  --pid-file '' --quiet >/tmp/navd-loop.out 2>&1
rc=$?
kill $feeders 2>/dev/null
wait $feeders 2>/dev/null
sed 's/^/BOARD LOG navd (loop): /' /tmp/navd-loop.out
cat /tmp/feed*.out | sed 's/^/BOARD INFO /'
if [ $rc -eq 0 ] && [ -f /tmp/loop.csv ]; then
  sed 's/^/BOARD POSE /' /tmp/loop.csv
else
  fail "loop-navd: exit $rc, $(tail -n 2 /tmp/navd-loop.out | tr '\n' ' ')"
fi

# 6b. A moving sweep through the loopback: SWEEP_FRAMES rendered frame sets, one per capture.
#     board-loop slows each capture to one frame per SWEEP_PERIOD_MS (the render's frame
#     period, custom DV timings) and holds frame set i on an output until that camera has
#     captured one frame of it (seen in the driver's bookkeeping of navd's buffers and told by
#     its pixels), then shows i + 1. navd from the truth pose of frame set 0; its poses
#     (BOARD SWEEP) and what each capture held (BOARD CAPTURE) go to the host, which replays the
#     same frames with navd's frame-set stamps and compares.
args=""
k=0
for cam in $LOOP_CAMERAS; do
  args="$args /dev/video$k /dev/video$((k + NUM_CAMERAS)) /board/sweep/$cam"
  k=$((k + 1))
done
board-loop sweep "$SWEEP_PERIOD_MS" "$SWEEP_FRAMES" $args >/tmp/sweep-feed.out 2>&1 &
feeder=$!
n=0
while ! grep -q 'ready' /tmp/sweep-feed.out && kill -0 $feeder 2>/dev/null && [ $n -lt 100 ]; do usleep 100000; n=$((n + 1)); done
if grep -q 'ready' /tmp/sweep-feed.out; then
  a=$(cut -d' ' -f1 /proc/uptime)
  # On CPU 0 with the feeder (SCHED_FIFO there): it sees each capture before navd is done with it.
  taskset 1 mfns-navd --params /board/sweep.bin --source v4l2 --frames "$SWEEP_FRAMES" --initial-pose "$SWEEP_POSE" \
    --deadline-ms "$SWEEP_PERIOD_MS" --timeout-ms 2000 --log /tmp/sweep.csv --pid-file '' --quiet >/tmp/navd-sweep.out 2>&1
  rc=$?
  b=$(cut -d' ' -f1 /proc/uptime)
  kill $feeder 2>/dev/null
else
  rc=1
  echo "mfns-navd: not run: the feeder did not start" >/tmp/navd-sweep.out
fi
wait $feeder
frc=$?
sed 's/^/BOARD LOG navd (sweep): /' /tmp/navd-sweep.out
if [ -n "${a:-}" ]; then
  info "sweep: $(grep -m 1 'ready' /tmp/sweep-feed.out | sed 's/^board-loop: ready: //'); navd ran $(awk -v a="$a" -v b="$b" 'BEGIN{printf "%.1f", b - a}') s"
fi
pacing=$(grep -E '^board-loop: (ok|bad) ' /tmp/sweep-feed.out | sed 's/^board-loop: [a-z]* //' | tr '\n' ';')
if [ $frc -eq 0 ] && [ -n "$pacing" ]; then
  pass "sweep-pacing: $pacing"
else
  fail "sweep-pacing: feeder exit $frc: $(grep -v -e ready -e '^capture ' /tmp/sweep-feed.out | sed 's/^board-loop: //' | tr '\n' ';')"
fi
# Which frame set each capture held, for the host to replay the frames as navd got them.
sed -n 's/^capture /BOARD CAPTURE /p' /tmp/sweep-feed.out
if [ $rc -eq 0 ] && [ -f /tmp/sweep.csv ]; then
  sed 's/^/BOARD SWEEP /' /tmp/sweep.csv
else
  fail "sweep-navd: exit $rc, $(tail -n 2 /tmp/navd-sweep.out | tr '\n' ' ')"
fi
k=0
while [ $k -lt "$NUM_CAMERAS" ]; do board-ctl /dev/video$k 'Loop Video' 0; k=$((k + 1)); done

# 7. The unit's command line as systemd would run it (no systemd here): ExecStart from the
#    installed unit, MFNS_NAVD_ARGS from its EnvironmentFile, split at white space; --frames
#    added so that it ends.
unit=/usr/lib/systemd/system/mfns-navd.service
execstart=$(sed -n 's/^ExecStart=//p' $unit)
envfile=$(sed -n 's/^EnvironmentFile=//p' $unit)
( set -a; . "$envfile"; set +a; eval "exec $execstart --frames 3" ) >/tmp/unit.out 2>&1
rc=$?
if [ $rc -eq 0 ] && grep -q 'done: 3 frame sets' /tmp/unit.out && ! grep -q 'did not start' /tmp/unit.out; then
  pass "unit-execstart: '$execstart' with $envfile: $(grep 'done:' /tmp/unit.out | sed 's/^mfns-navd: //')"
else
  fail "unit-execstart: '$execstart' with $envfile: exit $rc, $(tail -n 3 /tmp/unit.out | tr '\n' ' ')"
fi

# 8. The gtest cases that hang under qemu-user (threads blocked around FIFOs and flock there;
#    the aarch64 test preset excludes them), natively on this kernel: each test executable with
#    the filter, under a timeout of its own so that a hang fails its line and the others still
#    run. paramctl_test's subprocess cases run the package's mfns-paramctl, installed above: the
#    build tree's binary and the qemu-aarch64 the test would run it with are not on the board.
for t in $GTEST_BINS; do
  a=$(cut -d' ' -f1 /proc/uptime)
  MFNS_PARAMCTL_BINARY=/usr/bin/mfns-paramctl timeout -k 5 "$GTEST_TIMEOUT" /board/tests/$t \
    --gtest_filter="$GTEST_FILTER" >/tmp/$t.out 2>&1
  rc=$?
  b=$(cut -d' ' -f1 /proc/uptime)
  ok=$(grep -c '^\[       OK \]' /tmp/$t.out)
  bad=$(grep -c '^\[  FAILED  \] .* ([0-9]* ms)$' /tmp/$t.out)  # per test; the summary's list has no time
  names=$(sed -n 's/^\[ RUN      \] //p' /tmp/$t.out | tr '\n' ' ' | sed 's/ $//')
  detail="$ok passed, $bad failed in $(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.1f", b - a }') s ($names)"
  if [ $rc -eq 0 ] && [ "$ok" -gt 0 ] && [ "$bad" -eq 0 ]; then
    pass "gtest-$t: $detail"
  else
    case $rc in
      124 | 137 | 143) why="killed by the $GTEST_TIMEOUT s timeout (exit $rc)" ;;
      0) why="exit 0, no test matched --gtest_filter=$GTEST_FILTER" ;;
      *) why="exit $rc" ;;
    esac
    # the failures' messages, without gtest's progress lines and banner
    grep -v -e '^\[' -e '^$' -e '^Running main() from ' -e '^Note: Google Test filter' /tmp/$t.out | head -n 40 |
      sed "s/^/BOARD LOG gtest-$t: /"
    fail "gtest-$t: $why, $detail"
  fi
done

# 9. The package removes cleanly and keeps the parameter store.
if dpkg -r mfns >/tmp/dpkg-r.out 2>&1 && [ ! -e /usr/bin/mfns-navd ] && [ -d /var/lib/mfns/params ]; then
  pass "dpkg-remove: binaries gone, store kept ($(ls /var/lib/mfns/params | tr '\n' ' '))"
else
  fail "dpkg-remove: $(tr '\n' ' ' </tmp/dpkg-r.out)"
fi
echo "BOARD CHECKS COMPLETE"
