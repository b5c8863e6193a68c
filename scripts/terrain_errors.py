#!/usr/bin/python3
"""Where a terrain map's slope errors are, and what hazard precision and recall its accuracy permits (issue 11).

terrain_eval gives one RMSE and one precision/recall for a whole map. This breaks the slope error at the map's
resolution (the truth seen through its plane-fit support, terrain/resolution.h, written by
`terrain_eval --write-truth-at-resolution`) down by the distance of a cell from the edge of the known cells and by
the true slope, says which threshold makes the true hazards (slope or roughness), how many cells sit near the slope
threshold, and what precision and recall the true slopes of the same cells would give with white noise of a given
sigma added (seeded): the slope accuracy a precision/recall target needs on this terrain. When the map has the shading
relief (layer shading_slope_deg, terrain/shading_relief.h), how well it separates the cells the truth (as sampled, the
4 m footprint) calls rough from the truly safe ones: ROC AUC, percentiles and the share of each flagged by thresholds.

  /usr/bin/python3 scripts/terrain_errors.py --gt DATASET_DIR --est DIR [--work DIR] [--max-slope-deg 10]
        [--max-roughness-m 0.3] [--seed 1]

DIR: a terrain map (vo_run --output-terrain DIR, or hazard_recorder's folder). Needs numpy and scipy (Debian
python3-numpy, python3-scipy).
"""
import argparse
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np
from scipy import ndimage

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build")), "devel", "lib",
                   "planetary_vo")


def read_tiff(path):
    """A single-channel 32-bit float TIFF as OpenCV writes the grid layers (uncompressed strips)."""
    with open(path, "rb") as f:
        b = f.read()
    bo = {b"II": "<", b"MM": ">"}.get(b[:2])
    if bo is None:
        sys.exit(f"terrain_errors: {path} is not a TIFF")
    off = struct.unpack(bo + "I", b[4:8])[0]
    n = struct.unpack(bo + "H", b[off:off + 2])[0]
    sizes = {1: (1, "B"), 3: (2, "H"), 4: (4, "I")}
    tags = {}
    for i in range(n):
        e = b[off + 2 + 12 * i: off + 14 + 12 * i]
        tag, typ, cnt = struct.unpack(bo + "HHI", e[:8])
        if typ not in sizes:
            continue
        size, fmt = sizes[typ]
        if size * cnt <= 4:
            tags[tag] = struct.unpack(bo + fmt * cnt, e[8:8 + size * cnt])
        else:
            at = struct.unpack(bo + "I", e[8:12])[0]
            tags[tag] = struct.unpack(bo + fmt * cnt, b[at:at + size * cnt])
    if tags.get(259, (1,))[0] != 1 or tags.get(258, (32,))[0] != 32 or tags.get(339, (3,))[0] != 3:
        sys.exit(f"terrain_errors: {path}: only uncompressed 32-bit float layers are read")
    w, h = tags[256][0], tags[257][0]
    data = b"".join(b[o:o + c] for o, c in zip(tags[273], tags[279]))
    return np.frombuffer(data, dtype=bo + "f4", count=w * h).reshape(h, w).astype(np.float64)


def rms(x):
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gt", required=True, help="the dataset (its groundtruth_terrain grids)")
    ap.add_argument("--est", required=True, help="the terrain map's folder (terrain.yaml and layers)")
    ap.add_argument("--work", default="", help="where terrain_eval writes the truth at resolution (default: temp)")
    ap.add_argument("--max-slope-deg", type=float, default=10.0)
    ap.add_argument("--max-roughness-m", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--shading-thresholds", default="2,2.5,3,3.5,4",
                    help="thresholds (deg) at which the shading relief's flagged shares are printed")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="terrain_errors_")
    cmd = [os.path.join(BIN, "terrain_eval"), "--gt", a.gt, "--est", a.est, "--max-slope-deg", str(a.max_slope_deg),
           "--max-roughness-m", str(a.max_roughness_m), "--write-truth-at-resolution", work]
    if subprocess.call(cmd, stdout=subprocess.DEVNULL) != 0:
        sys.exit("terrain_errors: " + " ".join(cmd) + " failed")
    ts = read_tiff(os.path.join(work, "truth_at_resolution_slope_deg.tiff"))
    tr = read_tiff(os.path.join(work, "truth_at_resolution_roughness_m.tiff"))
    es = read_tiff(os.path.join(a.est, "terrain_slope_deg.tiff"))
    er = read_tiff(os.path.join(a.est, "terrain_roughness_m.tiff"))
    cell = 0.5
    try:
        import yaml
        with open(os.path.join(a.est, "terrain.yaml")) as f:
            cell = float(yaml.safe_load(f)["geometry"]["cell_size_m"])
    except Exception:  # PyYAML missing or another layout: the default cell
        pass
    m = np.isfinite(es) & np.isfinite(ts) & np.isfinite(er) & np.isfinite(tr)
    print(f"{a.est}: {int(m.sum())} cells with an estimated and a true slope (at the map's resolution)")
    print(f"  slope RMSE {rms((es - ts)[m]):.2f} deg")
    dist = ndimage.distance_transform_edt(np.isfinite(es)) * cell
    print("  by distance from the edge of the known cells:")
    for lo, hi in [(0, 2), (2, 4), (4, 8), (8, 16), (16, np.inf)]:
        s = m & (dist >= lo) & (dist < hi)
        print(f"    {lo:4.0f}-{hi:<4.0f} m: {int(s.sum()):6d} cells, RMSE {rms((es - ts)[s]):.2f} deg")
    print("  by true slope (the mean error shows a bias):")
    for lo, hi in [(0, 5), (5, 8), (8, 10), (10, 12), (12, 15), (15, 90)]:
        s = m & (ts >= lo) & (ts < hi)
        if s.any():
            d = (es - ts)[s]
            print(f"    {lo:2.0f}-{hi:<2.0f} deg: {int(s.sum()):6d} cells, mean {d.mean():+.2f}, RMSE {rms(d):.2f} deg, "
                  f"estimated above {a.max_slope_deg:g}: {np.mean(es[s] > a.max_slope_deg):.2f}")
    t_slope, t_rough = ts > a.max_slope_deg, tr > a.max_roughness_m
    true_h = (t_slope | t_rough) & m
    print(f"  true hazards: {int(true_h.sum())} cells: slope {int((t_slope & m).sum())}, roughness "
          f"{int((t_rough & m).sum())}, both {int((t_slope & t_rough & m).sum())}")
    near = np.abs(ts[m] - a.max_slope_deg)
    print("  cells whose true slope is within 1 / 2 / 3 deg of the threshold: "
          + " / ".join(f"{np.mean(near < k):.2f}" for k in (1, 2, 3)))
    est_h = ((es > a.max_slope_deg) | (er > a.max_roughness_m)) & m
    tp = int((est_h & true_h).sum())
    print(f"  hazard precision {tp / max(1, est_h.sum()):.3f}, recall {tp / max(1, true_h.sum()):.3f} (this map)")
    rng = np.random.default_rng(a.seed)
    print("  the true slopes of these cells plus white noise (5 draws each; roughness as estimated):")
    for sigma in (0.25, 0.5, 0.75, 1.0, 1.5, 2.0):
        p, r = [], []
        for _ in range(5):
            noisy = (ts[m] + rng.normal(0.0, sigma, int(m.sum())) > a.max_slope_deg) | (er[m] > a.max_roughness_m)
            hit = int((noisy & true_h[m]).sum())
            p.append(hit / max(1, noisy.sum()))
            r.append(hit / max(1, true_h[m].sum()))
        print(f"    sigma {sigma:4.2f} deg: precision {np.mean(p):.2f}, recall {np.mean(r):.2f}")
    shading_path = os.path.join(a.est, "terrain_shading_slope_deg.tiff")
    if os.path.exists(shading_path):
        shading_report(read_tiff(shading_path), a)


def auc(pos, neg):
    """Probability that a random positive scores above a random negative (Mann-Whitney, ties broken by order)."""
    ranks = np.concatenate([pos, neg]).argsort().argsort() + 1
    return (ranks[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2) / (len(pos) * len(neg))


def shading_report(v, a):
    """The shading relief against the truth as sampled (the 4 m footprint's slope and roughness)."""
    ts = read_tiff(os.path.join(a.gt, "groundtruth_terrain_slope_deg.tiff"))
    tr = read_tiff(os.path.join(a.gt, "groundtruth_terrain_roughness_m.tiff"))
    ok = np.isfinite(v) & np.isfinite(ts) & np.isfinite(tr)
    rough = ok & (tr > a.max_roughness_m)
    safe = ok & (ts <= a.max_slope_deg) & (tr <= a.max_roughness_m)
    print(f"  shading relief: {int(ok.sum())} cells measured; truly rough (> {a.max_roughness_m:g} m) "
          f"{int(rough.sum())}, truly safe {int(safe.sum())}")
    if not rough.any() or not safe.any():
        return
    print(f"    ROC AUC rough vs safe {auc(v[rough], v[safe]):.3f}; rough p5/p10/p50 "
          + "/".join(f"{x:.2f}" for x in np.percentile(v[rough], [5, 10, 50])) + " deg, safe p50/p80/p90 "
          + "/".join(f"{x:.2f}" for x in np.percentile(v[safe], [50, 80, 90])) + " deg")
    for th in [float(x) for x in a.shading_thresholds.split(",") if x]:
        print(f"    above {th:g} deg: rough {np.mean(v[rough] > th):.3f}, safe {np.mean(v[safe] > th):.3f}")


if __name__ == "__main__":
    main()
