#!/usr/bin/python3
"""How many cells a hazard map would certify as landing sites, and how many of those have a truly steep cell near
them, for several weights of the shading relief in the slope limit (issue 11, thresholds.shading_slope_weight).

The site search (terrain/landing_sites.h) certifies a cell when its slope raised by k sigma (the largest
slope_sigma_deg over the footprint disc) plus w times its shading relief is at most the slope limit, its shading
relief at most max_shading_slope_deg and it was not seen in shadow, and every cell within the clearance is certified
too. This replicates that qualification for the slope alone (roughness and its sigma are left out: the question is
the slopes the plane fit flattens) and counts, per weight, the qualifying cells and those with a true slope (as
sampled, over the 4 m footprint) above the limit within the clearance. Many more cells than the few sites a search
returns, so a denser statistic than the campaign's chosen sites; run it on maps the weight was not chosen on.

  /usr/bin/python3 scripts/slope_weight_check.py CAMPAIGN_DIR [CAMPAIGN_DIR ...] [--weights 0,0.5,1,2] [--k 2.5]
        [--max-slope-deg 10] [--max-shading-slope-deg 2.7] [--max-shadow-fraction 0.5] [--clearance-m 3]

CAMPAIGN_DIR: a scripts/hazard_campaign.py --runs output folder (runs/run_*/dataset and runs/run_*/terrain). Needs
numpy and scipy.
"""
import argparse
import glob
import os
import sys

import numpy as np
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from terrain_errors import read_tiff  # noqa: E402


def disc(radius_cells):
    """The footprint disc of terrain/surface_analysis.h: cell centres within the radius (on it included)."""
    r = int(np.floor(radius_cells + 1e-9))
    y, x = np.mgrid[-r:r + 1, -r:r + 1]
    return (x * x + y * y) <= radius_cells * radius_cells * (1 + 1e-12)


def disc_max(layer, footprint):
    """The largest value over each cell's disc; unknown (NaN) anywhere in it -> inf (never certified)."""
    v = np.where(np.isfinite(layer), layer, np.inf)
    return ndimage.grey_dilation(v, footprint=footprint, mode="constant", cval=-np.inf)


def layer(folder, prefix, name):
    path = os.path.join(folder, "%s_%s.tiff" % (prefix, name))
    return read_tiff(path) if os.path.exists(path) else None


def add_qualification_args(ap):
    """The site search's settings the qualification replicates (defaults: config/hazard.yaml's), shared with
    site_risk_check.py."""
    ap.add_argument("--k", type=float, default=2.5)
    ap.add_argument("--max-slope-deg", type=float, default=10.0)
    ap.add_argument("--max-shading-slope-deg", type=float, default=2.7)
    ap.add_argument("--max-shadow-fraction", type=float, default=0.5)
    ap.add_argument("--clearance-m", type=float, default=3.0)
    ap.add_argument("--footprint-m", type=float, default=4.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("campaigns", nargs="+")
    ap.add_argument("--weights", default="0,0.5,1,2")
    add_qualification_args(ap)
    a = ap.parse_args()
    weights = [float(w) for w in a.weights.split(",")]
    totals = {w: [0, 0] for w in weights}
    runs = sorted(r for c in a.campaigns for r in glob.glob(os.path.join(c, "runs", "run_*")))
    print("run: per weight w, cells qualifying / of them with a true slope above %g deg within %g m"
          % (a.max_slope_deg, a.clearance_m))
    for run in runs:
        est, gt = os.path.join(run, "terrain"), os.path.join(run, "dataset")
        slope = layer(est, "terrain", "slope_deg")
        truth = layer(gt, "groundtruth_terrain", "slope_deg")
        if slope is None or truth is None:
            continue
        cell = 0.5  # the landing area's cells (config/hazard.yaml); the truth is on the same grid
        sigma = layer(est, "terrain", "slope_sigma_deg")
        shading = layer(est, "terrain", "shading_slope_deg")
        shadow = layer(est, "terrain", "shadow_fraction")
        raised = slope + a.k * disc_max(sigma, disc(0.5 * a.footprint_m / cell))
        gate = np.ones(slope.shape, bool)
        if shading is None:
            shading = np.full(slope.shape, np.nan)
        gate &= ~(np.isfinite(shading) & (shading > a.max_shading_slope_deg))
        if shadow is not None:
            gate &= ~(np.isfinite(shadow) & (shadow > a.max_shadow_fraction))
        clearance = disc(a.clearance_m / cell)
        steep_near = ndimage.binary_dilation(truth > a.max_slope_deg, structure=clearance)
        row = os.path.relpath(run)
        for w in weights:
            upper = raised + w * np.where(np.isfinite(shading), shading, 0.0)
            certified = np.isfinite(upper) & (upper <= a.max_slope_deg) & gate
            sites = ndimage.binary_erosion(certified, structure=clearance, border_value=0)
            bad = int((sites & steep_near).sum())
            totals[w][0] += int(sites.sum())
            totals[w][1] += bad
            row += "  w %g: %d / %d" % (w, sites.sum(), bad)
        print(row)
    print("all %d maps:" % len(runs))
    for w in weights:
        n, bad = totals[w]
        print("  w %g: %d cells qualify, %d (%.1f %%) with a true slope above %g deg within %g m"
              % (w, n, bad, 100.0 * bad / max(1, n), a.max_slope_deg, a.clearance_m))


if __name__ == "__main__":
    main()
