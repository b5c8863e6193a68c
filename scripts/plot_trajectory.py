#!/usr/bin/env python3
"""Plots of a trajectory evaluation, from the per-pose CSV written by vo_eval (--plot DIR).

Writes into --out:
  trajectory.png        3D path and top view (crossrange x / downrange y), estimate vs ground truth
  position_vs_time.png  crossrange x, downrange y, altitude z vs time, estimate vs ground truth, with their errors
  attitude.png          quaternion components of T_world_cam vs time, estimate vs ground truth
  ate_vs_time.png       absolute translation and rotation error vs time
  gnc_errors.png        navigation errors vs time: position error (and % of the distance travelled), velocity
                        error (norm and world components), attitude and tilt error, scale error over the trailing
                        window, and NEES of the position with its 95 % per-pose bounds when a covariance was given

Uses the Agg backend (no display). Debian: apt install python3-matplotlib.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend choice)

AXES = {"landing": ("crossrange x", "downrange y", "altitude z"), "xyz": ("x", "y", "z")}
NAMES = AXES["landing"]
GT_STYLE = dict(color="black", linestyle="--", linewidth=1.2, label="ground truth")
EST_STYLE = dict(color="tab:blue", linewidth=1.2, label="estimate")


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_trajectory: {path} has no pose")
    return {key: [float(r[key]) for r in rows] for key in rows[0]}


def save(fig, out_dir, name, title, subtitle):
    fig.suptitle(f"{title}\n{subtitle}" if subtitle else title, fontsize=10)
    fig.tight_layout()
    path = os.path.join(out_dir, name)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"  {path}")


def plot_trajectory(d, out_dir, title, subtitle):
    fig = plt.figure(figsize=(12, 5.5))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.plot(d["gt_x_m"], d["gt_y_m"], d["gt_z_m"], **GT_STYLE)
    ax3.plot(d["est_x_m"], d["est_y_m"], d["est_z_m"], **EST_STYLE)
    ax3.scatter([d["gt_x_m"][0]], [d["gt_y_m"][0]], [d["gt_z_m"][0]], color="green", s=20, label="start")
    ax3.set_xlabel(f"{NAMES[0]} [m]")
    ax3.set_ylabel(f"{NAMES[1]} [m]")
    ax3.set_zlabel(f"{NAMES[2]} [m]")
    ax3.legend(fontsize=8)
    ax = fig.add_subplot(1, 2, 2)
    ax.plot(d["gt_x_m"], d["gt_y_m"], **GT_STYLE)
    ax.plot(d["est_x_m"], d["est_y_m"], **EST_STYLE)
    ax.plot(d["gt_x_m"][0], d["gt_y_m"][0], "go", markersize=4)
    ax.set_xlabel(f"{NAMES[0]} [m]")
    ax.set_ylabel(f"{NAMES[1]} [m]")
    ax.set_title("top view (x-y)", fontsize=9)
    ax.axis("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, out_dir, "trajectory.png", title, subtitle)


def plot_position(d, out_dir, title, subtitle):
    t0 = d["t_s"][0]
    t = [x - t0 for x in d["t_s"]]
    fig, axes = plt.subplots(3, 2, figsize=(12, 8), sharex=True)
    for row, (axis, name) in enumerate(zip("xyz", NAMES)):
        ax = axes[row][0]
        ax.plot(t, d[f"gt_{axis}_m"], **GT_STYLE)
        ax.plot(t, d[f"est_{axis}_m"], **EST_STYLE)
        ax.set_ylabel(f"{name} [m]")
        ax.grid(True, alpha=0.3)
        ax = axes[row][1]
        ax.plot(t, d[f"err_{axis}_m"], color="tab:red", linewidth=1.0)
        ax.axhline(0.0, color="gray", linewidth=0.6)
        ax.set_ylabel(f"{name} error [m]")
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=8)
    axes[2][0].set_xlabel("time [s]")
    axes[2][1].set_xlabel("time [s]")
    save(fig, out_dir, "position_vs_time.png", title, subtitle)


def plot_attitude(d, out_dir, title, subtitle):
    t0 = d["t_s"][0]
    t = [x - t0 for x in d["t_s"]]
    fig, axes = plt.subplots(4, 1, figsize=(10, 8), sharex=True)
    for ax, c in zip(axes, ["qx", "qy", "qz", "qw"]):
        ax.plot(t, d[f"gt_{c}"], **GT_STYLE)
        ax.plot(t, d[f"est_{c}"], **EST_STYLE)
        ax.set_ylabel(c)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title("attitude quaternion of the camera in the world (T_world_cam)", fontsize=9)
    axes[-1].set_xlabel("time [s]")
    save(fig, out_dir, "attitude.png", title, subtitle)


def plot_ate(d, out_dir, title, subtitle):
    t0 = d["t_s"][0]
    t = [x - t0 for x in d["t_s"]]
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    axes[0].plot(t, d["ate_m"], color="tab:red", linewidth=1.0)
    axes[0].set_ylabel("translation error [m]")
    axes[0].grid(True, alpha=0.3)
    axes[1].plot(t, d["rot_err_deg"], color="tab:purple", linewidth=1.0)
    axes[1].set_ylabel("rotation error [deg]")
    axes[1].set_xlabel("time [s]")
    axes[1].grid(True, alpha=0.3)
    save(fig, out_dir, "ate_vs_time.png", title, subtitle)


# Two-sided 95 % bounds of one chi-square value with 3 degrees of freedom (quantiles 0.025 and 0.975), the
# per-pose NEES bounds of a position (vo_eval computes the same values, JSON nees.position.pose_*_95).
CHI2_3DOF_95 = (0.2157952826, 9.3484036045)


def finite(values):
    return [v for v in values if v == v]


def plot_gnc(d, out_dir, title, subtitle):
    if "vel_err_mps" not in d:  # a CSV from an older vo_eval
        return
    t = d["t_rel_s"]
    has_nees = bool(finite(d["nees_pos"]))
    rows = 5 if has_nees else 4
    fig, axes = plt.subplots(rows, 1, figsize=(10, 2.3 * rows + 1.0), sharex=True)
    ax = axes[0]
    ax.plot(t, d["ate_m"], color="tab:red", linewidth=1.0, label="position error")
    ax.set_ylabel("position error [m]")
    ax.grid(True, alpha=0.3)
    # In % of the distance travelled, from 5 % of the final distance on (the ratio is meaningless at the start).
    min_dist = 0.05 * max(d["dist_m"])
    pct = [100.0 * e / s if s > min_dist and s > 0 else float("nan") for e, s in zip(d["ate_m"], d["dist_m"])]
    if finite(pct):
        ax2 = ax.twinx()
        ax2.plot(t, pct, color="tab:gray", linewidth=0.8, linestyle=":")
        ax2.set_ylabel("dotted: % of distance", color="tab:gray")
    ax = axes[1]
    ax.plot(t, d["vel_err_mps"], color="black", linewidth=1.2, label="|error|")
    for axis, name, color in zip("xyz", NAMES, ("tab:blue", "tab:orange", "tab:green")):
        ax.plot(t, d[f"vel_err_{axis}_mps"], color=color, linewidth=0.8, label=name)
    ax.axhline(0.0, color="gray", linewidth=0.6)
    ax.set_ylabel("velocity error [m/s]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=4)
    ax = axes[2]
    ax.plot(t, d["rot_err_deg"], color="tab:purple", linewidth=1.0, label="attitude error")
    ax.plot(t, d["tilt_err_deg"], color="tab:cyan", linewidth=1.0, label="tilt error (gravity direction)")
    ax.set_ylabel("angle [deg]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    ax = axes[3]
    ax.plot(t, d["scale_err_pct"], color="tab:brown", linewidth=1.0, marker=".", markersize=3)
    ax.axhline(0.0, color="gray", linewidth=0.6)
    ax.set_ylabel("scale error [%]\n(trailing window)")
    ax.grid(True, alpha=0.3)
    if has_nees:
        ax = axes[4]
        ax.semilogy(t, d["nees_pos"], color="tab:red", linewidth=0.8, marker=".", markersize=2)
        ax.axhline(3.0, color="black", linewidth=0.8, label="expected (3 dof)")
        for bound in CHI2_3DOF_95:
            ax.axhline(bound, color="gray", linewidth=0.8, linestyle="--")
        positive = [v for v in finite(d["nees_pos"]) if v > 0]
        # An exact pose has NEES ~1e-15: do not spend the axis on such decades.
        ax.set_ylim(bottom=max(1e-3, 0.5 * min(positive)) if positive else 1e-3)
        ax.set_ylabel("position NEES")
        ax.grid(True, alpha=0.3, which="both")
        ax.legend(fontsize=7)
    axes[-1].set_xlabel("time since the first pose [s]")
    save(fig, out_dir, "gnc_errors.png", title, subtitle)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--csv", required=True, help="pose_errors.csv written by vo_eval")
    parser.add_argument("--out", required=True, help="output folder for the PNG files")
    parser.add_argument("--title", default="trajectory evaluation")
    parser.add_argument("--subtitle", default="")
    parser.add_argument("--axes", choices=sorted(AXES), default="landing",
                        help="axis names: landing-site frame (crossrange x, downrange y, altitude z) or plain x y z")
    args = parser.parse_args()
    global NAMES
    NAMES = AXES[args.axes]
    d = read_csv(args.csv)
    os.makedirs(args.out, exist_ok=True)
    plot_trajectory(d, args.out, args.title, args.subtitle)
    plot_position(d, args.out, args.title, args.subtitle)
    plot_attitude(d, args.out, args.title, args.subtitle)
    plot_ate(d, args.out, args.title, args.subtitle)
    plot_gnc(d, args.out, args.title, args.subtitle)


if __name__ == "__main__":
    main()
