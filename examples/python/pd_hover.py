#!/usr/bin/env python3
"""A PD position controller written in Python flying hexsim's square mission.

The controller runs at every autopilot tick (1 kHz) and acts at the attitude loop: it turns the
position and velocity error into a commanded acceleration a = kp·(p_sp − p) + kd·(v_sp − v) (NED),
the thrust vector f = m·(a − g) (g = +9.81 m/s² down), and the attitude whose body z axis points
along −f with the wanted yaw, plus |f| as collective thrust; hexsim's attitude and rate loops
follow it. Plain floats, no numpy inside the loop: Python's per-call cost is what limits the rate.

    python3 examples/python/pd_hover.py --out square.png     # the track, plotted with matplotlib (Agg)
"""
import argparse
import math

G_MPS2 = 9.80665
MAX_TILT_RAD = math.radians(30.0)
TAN_MAX_TILT = math.tan(MAX_TILT_RAD)
MIN_THRUST_OF_WEIGHT = 0.3


def quat_from_rotation(r):
    """(w, x, y, z) of the rotation matrix r (rows of a 3×3, columns are the body axes in NED)."""
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        return (0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s)
    if r[0][0] > r[1][1] and r[0][0] > r[2][2]:
        s = 2.0 * math.sqrt(1.0 + r[0][0] - r[1][1] - r[2][2])
        return ((r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s)
    if r[1][1] > r[2][2]:
        s = 2.0 * math.sqrt(1.0 + r[1][1] - r[0][0] - r[2][2])
        return ((r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s)
    s = 2.0 * math.sqrt(1.0 + r[2][2] - r[0][0] - r[1][1])
    return ((r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s)


class PDController:
    """Position PD → [q_w, q_x, q_y, q_z, thrust_N] for Simulation.act("attitude", ...).

    kp [1/s²] (m/s² per m), kd [1/s] (m/s² per m/s); the thrust never drops below
    MIN_THRUST_OF_WEIGHT·m·g (a downward command beyond that would turn the vehicle over) and the
    horizontal acceleration is limited so the tilt stays under MAX_TILT_RAD.
    """

    def __init__(self, mass_kg, kp=(1.2, 1.2, 3.0), kd=(1.8, 1.8, 3.0)):
        self.mass_kg = mass_kg
        self.kp = kp
        self.kd = kd

    def __call__(self, x, target_N_m, yaw_rad=0.0, v_sp_N_mps=(0.0, 0.0, 0.0)):
        """x: Simulation.state_vector() as a list; returns the attitude action."""
        kp, kd = self.kp, self.kd
        a_n = kp[0] * (target_N_m[0] - x[1]) + kd[0] * (v_sp_N_mps[0] - x[4])
        a_e = kp[1] * (target_N_m[1] - x[2]) + kd[1] * (v_sp_N_mps[1] - x[5])
        a_d = kp[2] * (target_N_m[2] - x[3]) + kd[2] * (v_sp_N_mps[2] - x[6])
        a_d = min(a_d, (1.0 - MIN_THRUST_OF_WEIGHT) * G_MPS2)  # never less thrust than that: stays upright
        a_h = math.hypot(a_n, a_e)
        a_h_max = (G_MPS2 - a_d) * TAN_MAX_TILT
        if a_h > a_h_max:
            a_n *= a_h_max / a_h
            a_e *= a_h_max / a_h
        m = self.mass_kg
        f_n, f_e, f_d = m * a_n, m * a_e, m * (a_d - G_MPS2)  # thrust vector, N, NED
        f = math.sqrt(f_n * f_n + f_e * f_e + f_d * f_d)
        zx, zy, zz = -f_n / f, -f_e / f, -f_d / f  # body z axis (down) in NED
        cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
        yx, yy, yz = -zz * sy, zz * cy, zx * sy - zy * cy  # y_b = z_b × (cos ψ, sin ψ, 0), normalised
        n = math.sqrt(yx * yx + yy * yy + yz * yz)
        yx, yy, yz = yx / n, yy / n, yz / n
        xx, xy, xz = yy * zz - yz * zy, yz * zx - yx * zz, yx * zy - yy * zx  # x_b = y_b × z_b
        q = quat_from_rotation(((xx, yx, zx), (xy, yy, zy), (xz, yz, zz)))
        return [q[0], q[1], q[2], q[3], f]


SQUARE_N_m = [(0.0, 0.0, -10.0), (40.0, 0.0, -10.0), (40.0, 40.0, -10.0), (0.0, 40.0, -10.0), (0.0, 0.0, -10.0)]


def fly_square(hexsim, seed=1, speed_mps=5.0, climb_mps=2.5, acceptance_m=1.0, hold_s=3.0):
    """Take off to 10 m at climb_mps, fly the 40 m square of worlds/missions/square.yaml at speed_mps,
    hover hold_s at the end. Returns the Simulation (finished) with its log."""
    sim = hexsim.Simulation(mission="square", seed=seed, estimator="truth", duration=120.0)
    pd = PDController(sim.hover_thrust_N / G_MPS2)
    x = sim.state_vector().tolist()
    for i, wp in enumerate(SQUARE_N_m):
        start = x[1:4]
        leg = [wp[k] - start[k] for k in range(3)]
        length = math.sqrt(sum(c * c for c in leg))
        t0 = x[0]
        speed = climb_mps if abs(leg[2]) > 0.5 * length else speed_mps
        yaw = math.atan2(leg[1], leg[0]) if i > 0 and length > 1.0 else 0.0
        while True:
            # A carrot moving along the leg at speed_mps, with the leg's velocity as feed-forward.
            s = min(1.0, (x[0] - t0) * speed / length) if length > 0 else 1.0
            v = [leg[k] / length * speed if s < 1.0 else 0.0 for k in range(3)] if length > 0 else [0.0] * 3
            carrot = [start[k] + s * leg[k] for k in range(3)]
            sim.act("attitude", pd(x, carrot, yaw, v))
            if not sim.step():
                return sim
            x = sim.state_vector().tolist()
            if s >= 1.0 and math.dist(x[1:4], wp) < acceptance_m:
                break
    t_end = x[0] + hold_s
    while x[0] < t_end and sim.step():
        sim.act("attitude", pd(x, SQUARE_N_m[-1], 0.0))
        x = sim.state_vector().tolist()
    return sim


def main():
    import hexsim  # noqa: E402 (after argparse so --help works without the module)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="square_track.png", help="PNG to write")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    sim = fly_square(hexsim, seed=args.seed)
    log = sim.log()
    fig, (top, alt) = plt.subplots(1, 2, figsize=(10, 4.5))
    top.plot([p[1] for p in SQUARE_N_m], [p[0] for p in SQUARE_N_m], "k--", lw=1, label="square")
    top.plot(log["pos_E_m"], log["pos_N_m"], lw=1.5, label="Python PD (truth)")
    top.set_xlabel("East (m)")
    top.set_ylabel("North (m)")
    top.set_aspect("equal")
    top.legend()
    alt.plot(log["t_s"], -log["pos_D_m"])
    alt.set_xlabel("t (s)")
    alt.set_ylabel("height (m)")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"flew the square in {sim.time_s:.1f} s -> {args.out}")


if __name__ == "__main__":
    main()
