#!/usr/bin/env python3
"""Hover in motors mode with a few lines of PD: the wrench a PD asks for, through the mixer's
pseudo-inverse, to rotor thrusts, to motor commands around the hover command.

    python3 motors_pd_hover.py [--seconds 10] [--seed 1] [--vehicle default_hex]

Prints the position error at the end; exit 1 when the vehicle did not hold within 0.5 m.
"""
import argparse
import sys

import numpy as np

import hexsim


def pd_motors(obs, env, kp=1.0, kd=1.5):
    """PD: observations (truth; one row or (n, 16)) -> one command per motor in [0, 1]. kp (1/s²) and
    kd (1/s) are the position and velocity gains: scalars or one per row."""
    obs = np.atleast_2d(obs)
    kp, kd = np.reshape(kp, (-1, 1)), np.reshape(kd, (-1, 1))
    e, v, q, w = obs[:, 0:3], obs[:, 3:6], obs[:, 6:10], obs[:, 10:13]   # NED m, m/s, q_NB, body rad/s
    a_N = kp * e - kd * v                                                 # wanted acceleration, NED m/s²
    thrust_N = env.mass_kg * (9.81 - a_N[:, 2])                           # collective along -z_B
    qw, qx, qy, qz = q.T
    roll = np.arctan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))
    pitch = np.arcsin(np.clip(2 * (qw * qy - qz * qx), -1, 1))
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    # Small angles, heading north: roll toward +E, pitch nose-down toward +N.
    attitude_error = np.stack([a_N[:, 1] / 9.81 - roll, -a_N[:, 0] / 9.81 - pitch, -yaw], axis=1)
    torque_Nm = (36.0 * attitude_error - 8.4 * w) @ env.inertia_kgm2.T    # ω_n 6 rad/s, damping 0.7
    wrench = np.concatenate([thrust_N[:, None], torque_Nm], axis=1)
    rotor_thrust_N = wrench @ np.linalg.pinv(env.mixer).T                  # mixer: wrench = A · thrusts
    per_rotor_hover_N = env.hover_thrust_N / env.rotors                    # thrust ∝ ω², ω roughly ∝ command
    commands = env.hover_command * np.sqrt(np.clip(rotor_thrust_N, 0, None) / per_rotor_hover_N)
    return np.clip(commands, 0.0, 1.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--vehicle", default="default_hex", help="a name under worlds/vehicles or a YAML path")
    args = ap.parse_args()
    env = hexsim.HoverEnv(act="motors", vehicle=args.vehicle, time_limit_s=args.seconds, start_offset_m=1.0)
    obs, info = env.reset(seed=args.seed)
    print(f"{env.rotors} rotors, hover command {env.hover_command:.3f}, spins {env.spin.tolist()}")
    total, worst = 0.0, 0.0
    while True:
        obs, reward, terminated, truncated, info = env.step(pd_motors(obs, env)[0])
        total += reward
        worst = max(worst, info["position_error_m"]) if info["t_s"] > args.seconds / 2 else worst
        if terminated or truncated:
            break
    print(f"after {info['t_s']:.1f} s: position error {info['position_error_m']:.3f} m "
          f"(worst over the second half {worst:.3f} m), return {total:.1f}")
    return 0 if not terminated and worst < 0.5 else 1


if __name__ == "__main__":
    sys.exit(main())
