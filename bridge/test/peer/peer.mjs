// An independent client of PX4's Simulator MAVLink API, written with node-mavlink (its own parser,
// CRC and CRC_EXTRA tables): it connects to `hexsim serve-px4`, flies the vehicle on the received
// sensors only (complementary attitude filter, baro + accel altitude filter, PD/PID loops, the
// airframe file's rotor geometry and hover thrust), answers every HIL_SENSOR with
// HIL_ACTUATOR_CONTROLS in lockstep, and writes what it decoded as JSON.
//
//   node peer.mjs --port P --airframe worlds/px4/quad_x.params --out peer.json
//                 [--alt 3] [--hold 30] [--battery-udp-port U]
//   node peer.mjs --vectors FILE    (writes framing test vectors produced by node-mavlink)
import { connect } from 'node:net';
import { createSocket } from 'node:dgram';
import { readFileSync, writeFileSync } from 'node:fs';
import {
  MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, minimal, common,
} from 'node-mavlink';

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };
const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) => {
  if (a.startsWith('--')) acc.push([a.slice(2), all[i + 1] && !all[i + 1].startsWith('--') ? all[i + 1] : true]);
  return acc;
}, []));

function hex(buf) { return [...buf].map((b) => b.toString(16).padStart(2, '0')).join(' '); }

if (args.vectors) {
  // Byte strings node-mavlink produces, for hexsim's C++ round-trip tests.
  const p = new MavLinkProtocolV2(1, 1);
  const act = new common.HilActuatorControls();
  act.timeUsec = 1002500n; act.flags = 1n; act.mode = 129;
  act.controls = [0.5, 0.25, -0.125, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
  const hb = new minimal.Heartbeat();
  hb.type = 2; hb.autopilot = 12; hb.baseMode = 0; hb.customMode = 0; hb.systemStatus = 0; hb.mavlinkVersion = 3;
  const cmd = new common.CommandLong();
  cmd._param1 = 115; cmd._param2 = 5000; cmd.command = 511; cmd.targetSystem = 0; cmd.targetComponent = 0;
  const sensor = new common.HilSensor();
  sensor.timeUsec = 1000000n; sensor.xacc = 0.1; sensor.yacc = -0.2; sensor.zacc = -9.81; sensor.xmag = 0.21;
  sensor.ymag = -0.03; sensor.zmag = 0.45; sensor.absPressure = 1013.25; sensor.pressureAlt = 0; sensor.temperature = 15;
  sensor.fieldsUpdated = 0x1fff; sensor.id = 0;
  const out = [
    { name: 'HIL_ACTUATOR_CONTROLS', seq: 7, hex: hex(p.serialize(act, 7)) },
    { name: 'HEARTBEAT', seq: 255, hex: hex(p.serialize(hb, 255)) },
    { name: 'COMMAND_LONG', seq: 0, hex: hex(p.serialize(cmd, 0)) },
    { name: 'HIL_SENSOR', seq: 3, hex: hex(p.serialize(sensor, 3)) },
  ];
  writeFileSync(args.vectors, JSON.stringify({ producer: 'node-mavlink', frames: out }, null, 1));
  process.exit(0);
}

// --- The airframe file: rotor geometry and hover command -------------------------------------
const params = {};
for (const line of readFileSync(args.airframe, 'utf8').split('\n')) {
  const m = line.match(/^param set-default (\S+) (\S+)/);
  if (m) params[m[1]] = Number(m[2]);
}
const nRotors = params.CA_ROTOR_COUNT;
const rotors = [...Array(nRotors).keys()].map((i) => ({
  x: params[`CA_ROTOR${i}_PX`], y: params[`CA_ROTOR${i}_PY`], km: params[`CA_ROTOR${i}_KM`],
}));
const hoverU = params.MPC_THR_HOVER;
const armLen = Math.max(...rotors.map((r) => Math.hypot(r.x, r.y)));

// --- Flight plan ---------------------------------------------------------------------------------
const altTarget = Number(args.alt ?? 3);
const holdS = Number(args.hold ?? 30);
const groundS = 1.0, climbRate = 1.0, settleS = 5.0;
const endS = groundS + altTarget / climbRate + settleS + holdS + 1.0;

// --- State ---------------------------------------------------------------------------------------
let roll = 0, pitch = 0, h = 0, vz = 0, altInt = 0, baroRef = null, baroSum = 0, baroN = 0, lastT = null;
const rec = { sensor_time_usec: [], mags: [], gps: 0, states: [], battery: [], udp_battery: [], setpoints: [],
  answered: 0, decode_errors: 0, hold_window_s: [groundS + altTarget / climbRate + settleS, endS - 1.0] };
const proto = new MavLinkProtocolV2(1, 1);
let seq = 0;
let done = false;

const sock = connect({ host: '127.0.0.1', port: Number(args.port) });
sock.setNoDelay(true);
const splitter = new MavLinkPacketSplitter();
const reader = sock.pipe(splitter).pipe(new MavLinkPacketParser());

function clamp(v, lo, hi) { return Math.min(hi, Math.max(lo, v)); }

function control(t, s) {
  const dt = lastT === null ? 0 : t - lastT;
  lastT = t;
  // Attitude: gyro integration, corrected towards the accelerometer's gravity direction (tau 2 s).
  const k = dt / (2.0 + dt);
  roll += s.xgyro * dt; pitch += s.ygyro * dt;
  roll += k * (Math.atan2(-s.yacc, -s.zacc) - roll);
  pitch += k * (Math.atan2(s.xacc, Math.hypot(s.yacc, s.zacc)) - pitch);
  // Vertical: up-acceleration from the specific force, corrected by the barometer.
  const upAcc = -(s.zacc * Math.cos(roll) * Math.cos(pitch)) - 9.80665;
  h += vz * dt; vz += upAcc * dt;
  if (s.fieldsUpdated & 0x1a00) {
    if (t < groundS) { baroSum += s.pressureAlt; baroN += 1; baroRef = baroSum / baroN; }
    if (baroRef !== null) { const e = s.pressureAlt - baroRef - h; h += 0.04 * e; vz += 0.02 * e; }
  }
  if (t < groundS) return Array(nRotors).fill(0);
  const sp = Math.min(altTarget, (t - groundS) * climbRate);
  rec.setpoints.push([t, sp, h]);
  altInt = clamp(altInt + (sp - h) * dt, -2, 2);
  const collective = clamp(hoverU * (1 + 0.25 * (sp - h) - 0.35 * vz + 0.08 * altInt), 0.05, 0.95);
  // Rate-damped attitude hold (level), yaw rate damping.
  const tRoll = -0.25 * roll - 0.06 * s.xgyro;
  const tPitch = -0.25 * pitch - 0.06 * s.ygyro;
  const tYaw = -0.10 * s.zgyro;
  return rotors.map((r) => clamp(collective + (-r.y * tRoll + r.x * tPitch) / armLen
    + Math.sign(r.km) * tYaw, 0, 1));
}

function send(msg) { sock.write(proto.serialize(msg, seq)); seq = (seq + 1) & 255; }

reader.on('data', (packet) => {
  const clazz = REGISTRY[packet.header.msgid];
  if (!clazz) return;
  let d;
  try { d = packet.protocol.data(packet.payload, clazz); } catch (e) { rec.decode_errors += 1; return; }
  const name = clazz.MSG_NAME;
  if (done) return;
  if (name === 'HIL_SENSOR') {
    const t = Number(d.timeUsec - 1000000n) * 1e-6;
    if (d.fieldsUpdated & 0x1c0) rec.mags.push([Number(d.timeUsec), d.id, d.xmag, d.ymag, d.zmag]);
    if (d.id !== 0) return;
    rec.sensor_time_usec.push(Number(d.timeUsec));
    const u = control(t, d);
    const out = new common.HilActuatorControls();
    out.timeUsec = d.timeUsec;  // PX4 stamps its outputs with the clock HIL_SENSOR set
    out.flags = 1n;
    out.mode = 129;             // armed | custom
    out.controls = [...u, ...Array(16 - u.length).fill(0)];
    send(out);
    rec.answered += 1;
    if (t >= endS) { done = true; sock.end(); }
  } else if (name === 'HIL_GPS') {
    rec.gps += 1;
  } else if (name === 'HIL_STATE_QUATERNION') {
    rec.states.push([Number(d.timeUsec), d.alt]);
  } else if (name === 'BATTERY_STATUS') {
    rec.battery.push([d.voltages[0], d.currentBattery]);
  }
});

let udp = null;
if (args['battery-udp-port']) {
  udp = createSocket('udp4');
  const splitter = new MavLinkPacketSplitter();
  const parser = splitter.pipe(new MavLinkPacketParser());
  parser.on('data', (packet) => {
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz) return;
    const d = packet.protocol.data(packet.payload, clazz);
    rec.udp_battery.push([packet.header.sysid, packet.header.compid, d.voltages[0], d.currentBattery]);
  });
  udp.on('message', (m) => splitter.write(m));
  udp.bind(Number(args['battery-udp-port']), '127.0.0.1');
}

sock.on('close', () => {
  rec.parser_invalid_packets = splitter.invalidPackages;
  writeFileSync(args.out, JSON.stringify(rec));
  if (udp) udp.close();
  process.exit(0);
});
sock.on('error', (e) => { console.error('peer: ' + e.message); process.exit(1); });
