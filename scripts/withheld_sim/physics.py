"""Geometry and field helpers that mirror hexsim's own conventions (numpy only).

Conventions (read from the C++ sources, not guessed):
  - vehicle/io/src/vehicle_io.cc: R_SB = QuatFromEuler(roll, pitch, yaw)^T, the Euler angles ZYX,
    R_NB = Rz(yaw)·Ry(pitch)·Rx(roll) (common/include/hexsim/common/rotation.h).
  - magnetics/include/hexsim/magnetics/compass_model.h: reading H = R_SB·(scale·K(I)·B_B) + beta,
    K(I) = K + I_batt·dK/dI. The sensor gain M = R_SB·scale·K.
  - magnetics/src/current_field.cc: a wire segment a→b carrying I gives the Biot-Savart field of a
    finite straight conductor (mu0/4pi = 0.1 uT·m/A); the field follows sign(I)·|I|^exponent.
"""
import math

import numpy as np

MU0_OVER_4PI_UT_M_PER_A = 0.1  # 1e-7 T·m/A in µT·m/A


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def r_nb_from_rpy_deg(rpy_deg):
    r, p, y = (math.radians(v) for v in rpy_deg)
    return rot_z(y) @ rot_y(p) @ rot_x(r)


def rpy_deg_from_r_nb(R):
    """ZYX Euler angles (deg) of R_NB = Rz·Ry·Rx."""
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    roll = math.atan2(R[2, 1], R[2, 2])
    yaw = math.atan2(R[1, 0], R[0, 0])
    return [math.degrees(roll), math.degrees(pitch), math.degrees(yaw)]


def axis_angle(axis, angle_rad):
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle_rad) * K + (1 - math.cos(angle_rad)) * K @ K


def rotation_angle_deg(R):
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2))))


def random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def compass_r_sb(compass):
    return r_nb_from_rpy_deg(compass.get("orientation_rpy_deg", [0.0, 0.0, 0.0])).T


def compass_gain(compass):
    """M = R_SB·scale·K of a vehicle-file compass entry."""
    K = np.array(compass.get("soft_iron", np.eye(3).tolist()), dtype=float)
    return compass_r_sb(compass) @ (float(compass.get("scale", 1.0)) * K)


def segment_field_per_A(a, b, p):
    """Field (µT per A, body frame) at p of a straight segment a→b carrying +1 A."""
    a, b, p = (np.asarray(v, dtype=float) for v in (a, b, p))
    r1, r2 = p - a, p - b
    n1, n2 = np.linalg.norm(r1), np.linalg.norm(r2)
    denom = n1 * n2 * (n1 * n2 + r1 @ r2)
    if denom < 1e-18:
        return np.zeros(3)
    # Biot-Savart of a finite straight segment, current along a→b:
    # B = mu0/4pi·(|r1|+|r2|)/(|r1||r2|(|r1||r2| + r1·r2))·(r1 × r2); |B| = mu0/4pi·2·sin(alpha)/d.
    return MU0_OVER_4PI_UT_M_PER_A * (n1 + n2) / denom * np.cross(r1, r2)


def segment_near(p, target_uT_per_A, M, rng, half_length_m=0.04):
    """A segment (a, b) beside the point p whose field there, read through the sensor gain M, has the
    norm target_uT_per_A (solved for the distance by bisection). Returns (a, b, |M·g|)."""
    u = random_unit(rng)
    w = np.cross(u, random_unit(rng))
    w /= np.linalg.norm(w)
    p = np.asarray(p, dtype=float)

    def seg(r):
        c = p + r * w
        return c - half_length_m * u, c + half_length_m * u

    def field(r):
        a, b = seg(r)
        return np.linalg.norm(M @ segment_field_per_A(a, b, p))

    lo, hi = 0.002, 3.0
    for _ in range(80):
        mid = math.sqrt(lo * hi)
        if field(mid) > target_uT_per_A:
            lo = mid
        else:
            hi = mid
    a, b = seg(math.sqrt(lo * hi))
    return a, b, field(math.sqrt(lo * hi))
