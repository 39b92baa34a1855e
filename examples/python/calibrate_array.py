#!/usr/bin/env python3
"""Compass calibration from an (N, 3) array: free-hand samples in, offset and soft iron out.

Without arguments it makes its own samples (a 50 µT field seen at random attitudes through a known
hard iron offset, soft iron and 0.2 µT noise) and shows that the fit recovers them; with a file it
reads x,y,z rows (µT; numpy.loadtxt, comma or space separated) as `hexsim calibrate` would.

    python3 examples/python/calibrate_array.py [SAMPLES.txt] [--method auto|sphere|ellipsoid|robust]
"""
import argparse

import numpy as np

import hexsim


def synthetic_samples(n=500, field_uT=50.0, seed=1):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    earth = field_uT * u / np.linalg.norm(u, axis=1, keepdims=True)    # |B| = F at any attitude
    offset_uT = np.array([18.0, -9.0, 25.0])                           # hard iron
    K = np.array([[1.06, 0.02, 0.0], [0.02, 0.97, -0.03], [0.0, -0.03, 0.98]])
    K /= np.cbrt(np.linalg.det(K))                                     # soft iron, det 1
    return earth @ K.T + offset_uT + rng.normal(scale=0.2, size=(n, 3)), offset_uT


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("samples", nargs="?", help="x,y,z text file (default: synthetic samples)")
    parser.add_argument("--method", default="auto")
    args = parser.parse_args()
    if args.samples:
        raw, truth = np.loadtxt(args.samples, delimiter="," if open(args.samples).read(4096).count(",") else None), None
    else:
        raw, truth = synthetic_samples()
    fit = hexsim.calibrate(raw, method=args.method)
    print(f"method: {fit['method_used']} ({fit['why']})")
    print("offset_uT:", np.round(fit["offset_uT"], 3), "" if truth is None else f"(true {truth})")
    print("A:\n", np.round(fit["A"], 4))
    corrected = (raw - fit["offset_uT"]) @ fit["A"].T
    norms = np.linalg.norm(corrected, axis=1)
    before = np.linalg.norm(raw, axis=1)
    print(f"norm spread {100 * before.std() / before.mean():.2f} % -> {100 * norms.std() / norms.mean():.2f} %, "
          f"fit {'accepted' if fit['accepted'] else 'REJECTED by its gate'}")
    print(fit["ardupilot_parm"].strip())


if __name__ == "__main__":
    main()
