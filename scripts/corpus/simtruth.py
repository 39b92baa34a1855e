"""Simulated truth for the in-flight compass model at PX4 logging rates (issue 29): which of
`hexsim calibrate --method flight` and reference.py recovers a known current field.

hexsim flies a quad (quad_x) through yaw turns at up to ~210 deg/s (MISSION below, yaw-rate limits
raised as PX4 log_66 spins at up to 360 deg/s); from its 100 Hz truth this script builds the log a
PX4 autopilot would write: two compasses measured from the true attitude (mag: k = --k uT/A,
internal; mag2: --k2, external), sampled at --rate Hz with 10 % jitter and stamped --latency s
late, the attitude at 20 Hz (--att true: the true one; est: the simulator's estimator), the battery
current at 5 Hz, --stale s stale; the throttle shifted by --ulag (the simulated current lags the
command by ~0.18 s, a real ESC's by little: without it the throttle-based staleness absorbs it).
It writes OUTDIR/sim.csv + sim.meta.json (a FlightLog), runs hexsim calibrate on each compass and
reference.py's timed fit on the same samples, and prints both beside the truth (JSON).

usage: simtruth.py --hexsim BIN OUTDIR [--seed N] [--rate HZ] [--k kx,ky,kz] [--att true|est] ..."""
import argparse, json, os, subprocess, sys
import numpy as np

MISSION = """name: yawspin
speed_mps: 6
acceptance_radius_m: 1.5
yaw_mode: hold
wind: {mean_N_mps: [0, 3, 0], gust_std_mps: 0.8}
items:
  - {type: takeoff, alt_m: 8}
  - {type: waypoint, p_N_m: [20, 0, -15], speed_mps: 6, hold_s: 1, yaw_deg: 180}
  - {type: waypoint, p_N_m: [20, 20, -10], speed_mps: 10, hold_s: 1, yaw_deg: 0}
  - {type: waypoint, p_N_m: [0, 20, -20], speed_mps: 5, hold_s: 1, yaw_deg: 270}
  - {type: waypoint, p_N_m: [0, 0, -8], speed_mps: 10, hold_s: 1, yaw_deg: 90}
  - {type: waypoint, p_N_m: [15, 10, -18], speed_mps: 8, hold_s: 1, yaw_deg: -90}
  - {type: waypoint, p_N_m: [0, 0, -10], speed_mps: 6, hold_s: 1, yaw_deg: 45}
  - {type: land}
"""
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import extract, reference as R

ap = argparse.ArgumentParser()
ap.add_argument('out')
ap.add_argument('--k', default='0.1,-0.2,0.05'); ap.add_argument('--k2', default='0,0,0')
ap.add_argument('--rate', type=float, default=2.0); ap.add_argument('--latency', type=float, default=0.03)
ap.add_argument('--stale', type=float, default=0.1); ap.add_argument('--seed', type=int, default=1)
ap.add_argument('--noise', type=float, default=0.3); ap.add_argument('--att', default='est')
ap.add_argument('--hexsim', required=True); ap.add_argument('--sim-seed', type=int, default=3)
ap.add_argument('--ulag', type=float, default=0.18)
a = ap.parse_args()
rng = np.random.default_rng(a.seed)
os.makedirs(a.out, exist_ok=True)
with open(os.path.join(a.out, 'yawspin.yaml'), 'w') as fh:
    fh.write(MISSION)
run = subprocess.run([a.hexsim, 'run', os.path.join(a.out, 'yawspin.yaml'), '--vehicle', 'quad_x', '--seed',
                      str(a.sim_seed), '--out', os.path.join(a.out, 'flown'), '--set', 'control.limits.max_yaw_rate_dps=360',
                      'control.att.yaw.kp=8', 'control.rate.yaw.kp=1.0'], capture_output=True, text=True)
if run.returncode != 0:
    sys.exit('simtruth: hexsim run failed: ' + (run.stdout + run.stderr)[-400:])
d = np.genfromtxt(os.path.join(a.out, 'flown', 'log.csv'), delimiter=',', names=True)
t = d['t_s']
qt = np.vstack([d['q_w'], d['q_x'], d['q_y'], d['q_z']]).T
pre = 'est_q_' if a.att == 'est' else 'q_'
qe = np.vstack([d[pre + 'w'], d[pre + 'x'], d[pre + 'y'], d[pre + 'z']]).T
for q in (qt, qe):
    for i in range(1, len(q)):
        if np.dot(q[i], q[i - 1]) < 0: q[i] = -q[i]
I = d['current_A']
B = np.array([20.676, 1.458, 44.228]); c1 = np.array([7.0, 7.0, 0.0]); c2 = np.array([-3.0, 2.0, 5.0])
k1 = np.array([float(v) for v in a.k.split(',')]); k2 = np.array([float(v) for v in a.k2.split(',')])
def q_at(q, tq):
    qq = np.vstack([np.interp(tq, t, q[:, j]) for j in range(4)]).T
    return extract.quat_to_r(*qq.T)
# compass: measured at tau, stamped tau + L, one sample per 1/rate with +-10 % jitter
period = 1.0 / a.rate
tau = [t[0] + 0.3]
while tau[-1] + period < t[-1] - 0.5: tau.append(tau[-1] + period * (1 + 0.1 * rng.uniform(-1, 1)))
tau = np.array(tau)
Rt = q_at(qt, tau)
It = np.interp(tau, t, I)
m1 = np.einsum('nji,j->ni', Rt, B) + c1 + np.outer(It, k1) + a.noise * rng.standard_normal((len(tau), 3))
m2 = np.einsum('nji,j->ni', Rt, B) + c2 + np.outer(It, k2) + a.noise * rng.standard_normal((len(tau), 3))
stamp = tau + a.latency
# rows at 20 Hz (the attitude's rate)
rows = np.arange(t[0], t[-1], 0.05)
qrow = np.vstack([np.interp(rows, t, qe[:, j]) for j in range(4)]).T
qrow /= np.linalg.norm(qrow, axis=1)[:, None]
# current: 5 Hz updates, each the value S earlier
upd = np.floor(rows / 0.2) * 0.2
cur = np.interp(upd - a.stale, t, I)
u = np.interp(rows - a.ulag, t, d['control_u']); mot = [np.interp(rows, t, d['motor_%d_u' % j]) for j in range(1, 5)]
alt = -np.interp(rows, t, d['pos_D_m'])
armed = (alt > 0.3).astype(float)
idx = np.searchsorted(stamp, rows, side='right') - 1   # newest compass sample stamped by the row
os.makedirs(a.out, exist_ok=True)
cols = ['t_s', 'q_w', 'q_x', 'q_y', 'q_z', 'mag_t_s', 'mag_x_uT', 'mag_y_uT', 'mag_z_uT', 'mag2_t_s', 'mag2_x_uT',
        'mag2_y_uT', 'mag2_z_uT', 'batt_t_s', 'current_A', 'control_u', 'motor_1_u', 'motor_2_u', 'motor_3_u', 'motor_4_u', 'armed']
with open(os.path.join(a.out, 'sim.csv'), 'w') as fh:
    fh.write(','.join(cols) + '\n')
    for r in range(len(rows)):
        j = idx[r]
        if j < 0:                     # before the first compass sample: empty cells
            mt, m1v, m2v = float('nan'), [float('nan')] * 3, [float('nan')] * 3
        else:
            mt, m1v, m2v = stamp[j], m1[j], m2[j]
        vals = [rows[r], *qrow[r], mt, *m1v, mt, *m2v, upd[r], cur[r], u[r], *(m[r] for m in mot), armed[r]]
        fh.write(','.join('' if not np.isfinite(v) else '%.6f' % v for v in vals) + '\n')
meta = {"schema": "hexsim.log_meta/1", "location": {"lat_deg": 48.7678, "lon_deg": 11.3369, "alt_m": 376.0},
        "date_decimal_year": 2023.47, "motor_count": 4, "current_usable": True,
        "compasses": [{"column": "mag", "external": False}, {"column": "mag2", "external": True}]}
json.dump(meta, open(os.path.join(a.out, 'sim.meta.json'), 'w'))
# the reference's method on the same data: flight window = airborne rows, 2 s cut at each end
air = alt > 1.0
segs = extract.segments(rows, air)
res = {}
for name, m, k in (('mag', m1, k1), ('mag2', m2, k2)):
    tt = stamp; sel = extract.in_segments(tt, segs); tt, y = tt[sel], m[sel]
    Rr = extract.quat_to_r(*qrow.T)
    r = R.timed_fit(tt, y, lambda tq: R.attitude_at(rows, Rr, tq), lambda tq: R.interp(upd, cur, tq),
                    np.arange(0.0, R.MAX_SHIFT_S + 1e-9, R.SHIFT_STEP_S))
    res[name] = {'truth': float(np.linalg.norm(k) * 10), 'ref': [r['k_norm'] * 10, r['k_norm_lo'] * 10, r['k_norm_hi'] * 10],
                 'n': r['samples']}
    # hexsim calibrate
    cdir = os.path.join(a.out, 'cal_' + name)
    p = subprocess.run([a.hexsim, 'calibrate', os.path.join(a.out, 'sim.csv'), '--method', 'flight', '--compass', name,
                        '--out', os.path.join(cdir, 'calib.yaml')], capture_output=True, text=True)
    try:
        rep = json.load(open(os.path.join(cdir, 'calib.report.json')))
        cu = rep['flight_fit']['current']
        res[name]['hexsim'] = [cu['norm_mG_per_A']] + list(cu['norm_ci95_mG_per_A'])
        res[name]['hexsim_timing'] = rep['flight_fit']['timing']
    except (OSError, ValueError, KeyError) as e:
        res[name]['hexsim'] = 'failed: %s %s' % (e, (p.stdout + p.stderr)[-300:])
print(json.dumps(res))
