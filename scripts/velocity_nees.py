#!/usr/bin/python3
"""Consistency of an estimated velocity's covariance: the NEES (3 dof) of each estimate against the truth.

  /usr/bin/python3 scripts/velocity_nees.py --gt-state DATASET/groundtruth_state.txt --est-velocity v.txt

v.txt: lines t vx vy vz followed by the 3x3 covariance, row-major (vo_run --output-velocity without the IMU: the
motion filter's velocity, m/s in the world frame once metric). Only metric estimates in the ground truth's world
make sense here (vision + altimeter handed the first true pose; no alignment is applied). The truth is taken at
the estimate's stamp (within 1 ms) from groundtruth_state.txt (t p q v ...: v in columns 8-10). A consistent
covariance gives a mean NEES of 3 and 95 % of the estimates below 7.81 (chi-square, 3 dof).
"""
import argparse
import sys

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gt-state", required=True)
    ap.add_argument("--est-velocity", required=True)
    args = ap.parse_args()
    truth = {}
    for line in open(args.gt_state):
        if line.startswith("#") or not line.strip():
            continue
        f = [float(x) for x in line.split()]
        truth[round(f[0] * 1000)] = np.array(f[8:11])
    nees = []
    for n, line in enumerate(open(args.est_velocity), 1):
        if line.startswith("#") or not line.strip():
            continue
        f = [float(x) for x in line.split()]
        if len(f) != 13:
            sys.exit(f"velocity_nees: {args.est_velocity}:{n}: expected t, 3 velocity and 9 covariance values, "
                     f"got {len(f)}")
        v_true = truth.get(round(f[0] * 1000))
        if v_true is None:
            continue
        e = np.array(f[1:4]) - v_true
        P = np.array(f[4:13]).reshape(3, 3)
        nees.append(float(e @ np.linalg.solve(P, e)))
    if not nees:
        sys.exit("velocity_nees: no estimate at a ground-truth stamp")
    nees = np.array(nees)
    print(f"velocity NEES (3 dof) over {len(nees)} estimates: mean {nees.mean():.2f}, median {np.median(nees):.2f}, "
          f"p90 {np.percentile(nees, 90):.2f}; below 7.81 (95 % of chi-square 3): {100 * np.mean(nees < 7.81):.0f} %")


if __name__ == "__main__":
    main()
