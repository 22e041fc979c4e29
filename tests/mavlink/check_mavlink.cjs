#!/usr/bin/env node
// Issue 17 item 2: mfns-navd's MAVLink output read by an independent decoder, node-mavlink
// (its own CRC_EXTRA table and field layouts, generated from the published XML definitions).
//
// Usage: node check_mavlink.cjs POSES_CSV -- MFNS_NAVD ARGS...
// Binds two UDP sockets on 127.0.0.1, runs MFNS_NAVD ARGS with "{MAV_PORT}" and "{MFNS_PORT}"
// in ARGS replaced by their ports (so nothing races the bind), then checks what arrived against
// POSES_CSV (navd's --log) and the MFNS pose datagrams:
//   - every datagram is one MAVLink 2 packet that node-mavlink accepts (CRC with its CRC_EXTRA)
//     and re-encodes to the same bytes (truncation, CRC); sequence +1 per packet; ids 1/197;
//   - the packets in order are HEARTBEAT at the first frame set and then at each whole second
//     of sample time (t_ns), and ODOMETRY for every frame set that is not lost, nothing else;
//   - ODOMETRY fields equal the CSV row: time_usec = t_ns / 1000, x, y, z (m) = mm / 1000,
//     q (w, x, y, z of C_w_b) -> C_b_w -> the CSV's 2-1-3 Euler angles; frames LOCAL_FRD /
//     BODY_FRD, estimator VISION, quality 100 fix / 50 degraded, reset_counter +1 per track
//     after a lost stretch, velocities and velocity_covariance[0] NaN;
//   - pose_covariance symmetric positive definite and equal to the MFNS datagram's covariance of
//     [dr_w; dtheta_b] turned to [dr; dtheta about the local axes] (C_w_b from its q_w_b).
// Prints one line per check group; exits 1 with "FAIL: ..." on the first failure.
'use strict';
const dgram = require('dgram');
const fs = require('fs');
const { spawn } = require('child_process');
const {
  MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, minimal, common,
} = require('node-mavlink');
const { PassThrough } = require('stream');

function fail(msg) {
  console.error(`FAIL: ${msg}`);
  process.exit(1);
}
function check(ok, msg) {
  if (!ok) fail(msg);
}
const near = (a, b, tol) => Math.abs(a - b) <= tol;
const wrap180 = (d) => {
  let x = ((d + 180) % 360 + 360) % 360 - 180;
  if (x === -180) x = 180;
  return x;
};

// ---- poses CSV ----
function readCsv(path) {
  const lines = fs.readFileSync(path, 'utf8').trim().split('\n');
  const head = lines[0].split(',');
  return lines.slice(1).map((l) => {
    const v = l.split(',');
    const row = {};
    head.forEach((h, i) => { row[h] = v[i]; });
    return row;
  });
}

// ---- rotations (DESIGN.md: C_a_b maps b to a; 2-1-3 Euler C = R3(psi) R1(phi) R2(theta)) ----
function matrixOfQuaternion(w, x, y, z) {  // Hamilton, the rotation body -> local: C_w_b
  return [
    [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
  ];
}
const transpose = (m) => m[0].map((_, j) => m.map((r) => r[j]));
function euler213Deg(C) {  // phi = asin(-C21), theta = atan2(C20, C22), psi = atan2(C01, C11)
  const d = 180 / Math.PI;
  return [Math.asin(Math.max(-1, Math.min(1, -C[2][1]))) * d, Math.atan2(C[2][0], C[2][2]) * d,
    Math.atan2(C[0][1], C[1][1]) * d];
}

// ---- 6x6 helpers ----
function fromUpperTriangle(ut) {
  const P = [...Array(6)].map(() => Array(6).fill(0));
  let k = 0;
  for (let i = 0; i < 6; ++i) for (let j = i; j < 6; ++j) { P[i][j] = ut[k]; P[j][i] = ut[k]; ++k; }
  return P;
}
function isPositiveDefinite(P) {  // Cholesky
  const n = P.length, L = [...Array(n)].map(() => Array(n).fill(0));
  for (let i = 0; i < n; ++i) {
    for (let j = 0; j <= i; ++j) {
      let s = P[i][j];
      for (let k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
      if (i === j) { if (!(s > 0)) return false; L[i][i] = Math.sqrt(s); } else L[i][j] = s / L[j][j];
    }
  }
  return true;
}
function turnToLocal(P, C) {  // J P J^T with J = blockdiag(I, C_w_b)
  const J = [...Array(6)].map((_, i) => [...Array(6)].map((__, j) => (i < 3 && j < 3 ? (i === j ? 1 : 0)
    : i >= 3 && j >= 3 ? C[i - 3][j - 3] : 0)));
  const mul = (A, B) => A.map((r) => B[0].map((_, j) => r.reduce((s, a, k) => s + a * B[k][j], 0)));
  return mul(mul(J, P), transpose(J));
}

// ---- the MFNS pose datagram (firmware/modules/publish/pose_message.h) ----
function decodeMfnsPose(b) {
  if (b.length !== 208 || b.toString('latin1', 0, 4) !== 'MFNP' || b[5] !== 1) return null;
  const ut = [];
  for (let k = 0; k < 21; ++k) ut.push(b.readFloatLE(120 + 4 * k));
  return {
    t_capture_ns: b.readBigUInt64LE(16), status: b[40],
    r: [0, 1, 2].map((i) => b.readDoubleLE(48 + 8 * i)),
    q: [0, 1, 2, 3].map((i) => b.readDoubleLE(72 + 8 * i)),
    covariance: fromUpperTriangle(ut),
  };
}

async function main() {
  const sep = process.argv.indexOf('--');
  if (sep !== 3 || process.argv.length < 5) fail('usage: check_mavlink.cjs POSES_CSV -- MFNS_NAVD ARGS...');
  const csvPath = process.argv[2];
  const command = process.argv.slice(sep + 1);

  const datagrams = [], mfnsPoses = new Map();
  const mav = dgram.createSocket('udp4'), mfns = dgram.createSocket('udp4');
  mav.on('message', (m) => datagrams.push(m));
  mfns.on('message', (m) => {
    const p = decodeMfnsPose(m);
    if (p) mfnsPoses.set(p.t_capture_ns, p);
  });
  await Promise.all([mav, mfns].map((s) => new Promise((res) => s.bind(0, '127.0.0.1', res))));
  for (const s of [mav, mfns]) s.setRecvBufferSize(4 << 20);
  const args = command.slice(1).map((a) => a.replace('{MAV_PORT}', mav.address().port)
    .replace('{MFNS_PORT}', mfns.address().port));
  const child = spawn(command[0], args, { stdio: ['ignore', 'inherit', 'inherit'] });
  const code = await new Promise((res) => child.on('exit', res));
  check(code === 0, `mfns-navd exited ${code}`);
  await new Promise((res) => setTimeout(res, 300));  // the last datagrams
  mav.close();
  mfns.close();

  // 1. node-mavlink's splitter (CRC check with its CRC_EXTRA) and parser.
  const input = new PassThrough();
  const splitter = new MavLinkPacketSplitter();
  const packets = [];
  const parsed = input.pipe(splitter).pipe(new MavLinkPacketParser());
  parsed.on('data', (p) => packets.push(p));
  const done = new Promise((res) => parsed.on('end', res));
  for (const d of datagrams) input.write(d);
  input.end();
  await done;
  check(datagrams.length > 0, 'no MAVLink datagram received');
  check(splitter.invalidPackages === 0, `${splitter.invalidPackages} packets with a bad CRC`);
  check(splitter.unknownPackagesCount === 0, `${splitter.unknownPackagesCount} packets of unknown message ids`);
  check(packets.length === datagrams.length, `${packets.length} valid packets in ${datagrams.length} datagrams`);
  const REGISTRY = { 0: minimal.Heartbeat, 331: common.Odometry };
  const messages = packets.map((p, i) => {
    const h = p.header;
    check(datagrams[i][0] === 0xFD && h.incompatibilityFlags === 0, `packet ${i} is not an unsigned MAVLink 2 packet`);
    check(datagrams[i].length === 12 + h.payloadLength, `datagram ${i} holds more than one packet`);
    check(h.sysid === 1 && h.compid === 197, `packet ${i}: sysid ${h.sysid} compid ${h.compid}, expected 1 and 197`);
    check(h.seq === i % 256, `packet ${i}: sequence ${h.seq}`);
    const Clazz = REGISTRY[h.msgid];
    check(Clazz !== undefined, `packet ${i}: message id ${h.msgid}`);
    const m = p.protocol.data(p.payload, Clazz);
    // node-mavlink's own encoding of the decoded message: the same bytes (truncation, CRC).
    const again = new MavLinkProtocolV2(h.sysid, h.compid).serialize(m, h.seq);
    check(Buffer.compare(again, datagrams[i]) === 0, `packet ${i} (${Clazz.MSG_NAME}): node-mavlink encodes it as ` +
      `${again.toString('hex')}, received ${datagrams[i].toString('hex')}`);
    return { id: h.msgid, m };
  });
  console.log(`node-mavlink: ${datagrams.length} datagrams, each one valid MAVLink 2 packet (CRC, sequence, ids), ` +
    're-encoded byte for byte');

  // 2. Which packets, in which order: HEARTBEAT on the sample-time grid, ODOMETRY unless lost.
  const rows = readCsv(csvPath);
  check(rows.length > 0, 'empty poses CSV');
  let want = '', next = null;
  const heartbeatRows = [];
  for (const r of rows) {
    const t = BigInt(r.t_ns);
    if (next === null || t >= next) {
      want += 'H';
      heartbeatRows.push(r);
      next = (next === null || t >= next + 1000000000n ? t : next) + 1000000000n;
    }
    if (r.status !== 'lost') want += 'O';
  }
  const got = messages.map((x) => (x.id === 0 ? 'H' : 'O')).join('');
  check(got === want, `packet order ${got}, expected ${want}`);
  const span = Number(BigInt(rows[rows.length - 1].t_ns) - BigInt(rows[0].t_ns)) * 1e-9;
  const heartbeats = heartbeatRows.length;
  check(heartbeats >= Math.floor(span) && heartbeats <= Math.floor(span) + 1,
    `${heartbeats} heartbeats over ${span.toFixed(2)} s of sample time`);
  messages.filter((x) => x.id === 0).forEach((x, i) => {
    const hb = x.m, lost = heartbeatRows[i].status === 'lost';
    check(hb.type === 18 && hb.autopilot === 8 && hb.mavlinkVersion === 3 && hb.baseMode === 0,
      `heartbeat ${i}: type ${hb.type} autopilot ${hb.autopilot} version ${hb.mavlinkVersion}`);
    check(hb.systemStatus === (lost ? 5 : 4), `heartbeat ${i}: system_status ${hb.systemStatus} (row ${heartbeatRows[i].frame} ${heartbeatRows[i].status})`);
  });
  console.log(`order: ${heartbeats} HEARTBEATs over ${span.toFixed(2)} s of sample time, ` +
    `${messages.length - heartbeats} ODOMETRY for ${rows.filter((r) => r.status !== 'lost').length} frame sets not lost ` +
    `of ${rows.length}`);

  // 3. ODOMETRY against the CSV and the MFNS datagram.
  const posed = rows.filter((r) => r.status !== 'lost');
  let resets = 0, seenPose = false, lostSincePose = false, worstPosMm = 0, worstDeg = 0, worstCov = 0, matched = 0;
  const expectedReset = new Map();
  for (const r of rows) {
    if (r.status === 'lost') { lostSincePose = seenPose; continue; }
    if (lostSincePose) ++resets;
    lostSincePose = false;
    seenPose = true;
    expectedReset.set(r.frame, resets);
  }
  messages.filter((x) => x.id === 331).forEach((x, i) => {
    const o = x.m, r = posed[i], tag = `ODOMETRY ${i} (frame set ${r.frame})`;
    check(o.timeUsec === BigInt(r.t_ns) / 1000n, `${tag}: time_usec ${o.timeUsec}, t_ns ${r.t_ns}`);
    check(o.frameId === common.MavFrame.LOCAL_FRD && o.childFrameId === common.MavFrame.BODY_FRD,
      `${tag}: frames ${o.frameId}/${o.childFrameId}`);
    check(o.estimatorType === common.MavEstimatorType.VISION, `${tag}: estimator ${o.estimatorType}`);
    check(o.quality === (r.status === 'fix' ? 100 : 50), `${tag}: quality ${o.quality} for ${r.status}`);
    check(o.resetCounter === expectedReset.get(r.frame), `${tag}: reset_counter ${o.resetCounter}, expected ${expectedReset.get(r.frame)}`);
    check([o.vx, o.vy, o.vz, o.rollspeed, o.pitchspeed, o.yawspeed].every(Number.isNaN) &&
      Number.isNaN(o.velocityCovariance[0]), `${tag}: velocities not NaN`);
    const dp = Math.max(...['x_mm', 'y_mm', 'z_mm'].map((c, k) => Math.abs([o.x, o.y, o.z][k] * 1000 - Number(r[c]))));
    worstPosMm = Math.max(worstPosMm, dp);
    check(dp < 1e-3, `${tag}: position differs from the CSV by ${dp} mm`);
    const qn = Math.hypot(...o.q);
    check(near(qn, 1, 1e-6), `${tag}: |q| = ${qn}`);
    const C_w_b = matrixOfQuaternion(...o.q.map((v) => v / qn));
    const e = euler213Deg(transpose(C_w_b));
    const de = Math.max(...['roll_deg', 'pitch_deg', 'yaw_deg'].map((c, k) => Math.abs(wrap180(e[k] - Number(r[c])))));
    worstDeg = Math.max(worstDeg, de);
    check(de < 2e-4, `${tag}: attitude differs from the CSV by ${de} deg (${e} vs ${r.roll_deg},${r.pitch_deg},${r.yaw_deg})`);
    const P = fromUpperTriangle(o.poseCovariance);
    check(isPositiveDefinite(P), `${tag}: pose_covariance not positive definite`);
    const d = mfnsPoses.get(BigInt(r.t_ns));
    if (!d) return;
    ++matched;
    const Q = turnToLocal(d.covariance, matrixOfQuaternion(...d.q));
    for (let a = 0; a < 6; ++a) {
      for (let b = a; b < 6; ++b) {
        const scale = Math.sqrt(Q[a][a] * Q[b][b]);
        const rel = Math.abs(P[a][b] - Q[a][b]) / scale;
        worstCov = Math.max(worstCov, rel);
        check(rel < 1e-4, `${tag}: pose_covariance(${a},${b}) = ${P[a][b]}, datagram gives ${Q[a][b]}`);
      }
    }
  });
  check(matched === posed.length, `${matched} of ${posed.length} ODOMETRY matched to an MFNS pose datagram`);
  console.log(`odometry: ${posed.length} equal to the CSV (worst ${worstPosMm.toExponential(2)} mm, ` +
    `${worstDeg.toExponential(2)} deg), reset_counter ${resets} at the end; covariance positive definite and the ` +
    `datagram's turned to local axes (worst ${worstCov.toExponential(2)} of sigma_i sigma_j)`);
  console.log('PASS');
}

main().catch((e) => fail(e.stack || e));
