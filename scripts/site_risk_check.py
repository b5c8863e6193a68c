#!/usr/bin/python3
"""How many cells a hazard map would certify as landing sites, and how many of those have a truly hazardous cell
within the clearance, for several shading margins (issue 11, thresholds.shading_margin_m), split by the Sun's
elevation.

The site search (terrain/landing_sites.h) certifies a cell when
  - its slope raised by k sigma (the largest slope_sigma_deg over the footprint disc) plus w times its own shading
    relief is at most max_slope_deg,
  - its roughness raised by k sigma (the largest relief_sigma_m over the disc), and at least the largest
    residual_rms_m over the disc, is at most max_roughness_m,
  - no shading relief above max_shading_slope_deg lies within the shading margin of it,
  - it was not seen in shadow in more than max_shadow_fraction of its views,
and every cell within the clearance is certified too. This replicates that qualification (a layer the map does not
have is left out, as the search does) and counts, per margin, the qualifying cells and those with a true hazard
(slope above max_slope_deg or roughness above max_roughness_m, over the footprint as the truth defines them) within
the clearance. Many more cells than the few sites a search returns, so a denser statistic than a campaign's chosen
sites; run it on maps the margin was not chosen on.

--navigation-frame: the true terrain moved into the navigation's frame by the navigation's error at the end of the
run (the run's terrain_eval JSON, `navigation_error_m`, written by hazard_campaign.py), as terrain_eval's
"at touchdown" verdict does (terrain/terrain_score.h, truthInNavigationFrame): the ground the map saw at a cell,
and where a lander guided by that navigation to the cell touches down.

  /usr/bin/python3 scripts/site_risk_check.py CAMPAIGN_DIR [CAMPAIGN_DIR ...] [--margins 0,1,2] [--k 2.5]
        [--weight 0.5] [--max-slope-deg 10] [--max-roughness-m 0.3] [--max-shading-slope-deg 2.7]
        [--max-shadow-fraction 0.5] [--clearance-m 3] [--footprint-m 4] [--low-sun-deg 15] [--navigation-frame]

CAMPAIGN_DIR: a scripts/hazard_campaign.py --runs output folder (runs/run_*/dataset with the true terrain and
sequence.yaml, runs/run_*/terrain with the map). Needs numpy, scipy and yaml.
"""
import argparse
import glob
import json
import math
import os
import sys

import numpy as np
import yaml
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from slope_weight_check import add_qualification_args, disc, disc_max, layer  # noqa: E402


def sun_deg(dataset, key="elevation_deg"):
    """sun/<key> (deg) of a rendered dataset's sequence.yaml (elevation_deg, azimuth_deg); None when absent."""
    try:
        with open(os.path.join(dataset, "sequence.yaml")) as f:
            return float(yaml.safe_load(f)["sun"][key])
    except (OSError, KeyError, TypeError, ValueError):
        return None


def navigation_error(run):
    """The navigation's error (estimate - truth, m) at the end of a campaign run, from its terrain_eval JSON
    files (hazard_campaign.py runs terrain_eval --navigation-error-from); None when none of them has it."""
    for path in sorted(glob.glob(os.path.join(run, "t*.json"))):
        try:
            with open(path) as f:
                e = json.load(f).get("navigation_error_m")
        except (OSError, ValueError):
            continue
        if e:
            return e
    return None


def in_navigation_frame(grid, error_m, cell_m):
    """The layer moved by the navigation error (x, y) rounded to whole cells as truthInNavigationFrame does
    (half away from zero): cell (row, col) shows the ground at (row - dr, col - dc); NaN where that is outside."""
    def cells(v):
        return int(math.copysign(math.floor(abs(v / cell_m) + 0.5), v))
    dc, dr = cells(error_m[0]), cells(error_m[1])
    out = np.full_like(grid, np.nan)
    rows, cols = grid.shape
    out[max(0, dr):rows + min(0, dr), max(0, dc):cols + min(0, dc)] = \
        grid[max(0, -dr):rows + min(0, -dr), max(0, -dc):cols + min(0, -dc)]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("campaigns", nargs="+")
    ap.add_argument("--margins", default="0,1,2")
    add_qualification_args(ap)
    ap.add_argument("--weight", type=float, default=0.5, help="shading_slope_weight")
    ap.add_argument("--max-roughness-m", type=float, default=0.3)
    ap.add_argument("--cell-m", type=float, default=0.5, help="the landing area's cell size (config/hazard.yaml)")
    ap.add_argument("--low-sun-deg", type=float, default=15.0)
    ap.add_argument("--navigation-frame", action="store_true",
                    help="the truth moved by the navigation's error at the end of each run (see above)")
    a = ap.parse_args()
    margins = [float(m) for m in a.margins.split(",")]
    bins = ("Sun < %g deg" % a.low_sun_deg, "Sun >= %g deg" % a.low_sun_deg, "Sun not given")
    totals = {(b, m): [0, 0] for b in bins for m in margins}
    runs = sorted(r for c in a.campaigns for r in glob.glob(os.path.join(c, "runs", "run_*")))
    maps = 0
    print("run (Sun deg): per shading margin m, cells qualifying / of them with a true hazard within %g m"
          % a.clearance_m)
    for run in runs:
        est, gt = os.path.join(run, "terrain"), os.path.join(run, "dataset")
        slope, rough = layer(est, "terrain", "slope_deg"), layer(est, "terrain", "roughness_m")
        true_slope = layer(gt, "groundtruth_terrain", "slope_deg")
        true_rough = layer(gt, "groundtruth_terrain", "roughness_m")
        if slope is None or rough is None or true_slope is None or true_rough is None:
            continue
        if a.navigation_frame:
            error = navigation_error(run)
            if error is None:
                print("%s: no navigation error in its terrain_eval JSON (a run without a pose, or scored before "
                      "session 27: run hazard_campaign.py again with --reuse); left out" % os.path.relpath(run))
                continue
            true_slope = in_navigation_frame(true_slope, error, a.cell_m)
            true_rough = in_navigation_frame(true_rough, error, a.cell_m)
        maps += 1
        footprint = disc(0.5 * a.footprint_m / a.cell_m)
        sigma_s, sigma_r = layer(est, "terrain", "slope_sigma_deg"), layer(est, "terrain", "relief_sigma_m")
        residual = layer(est, "terrain", "residual_rms_m")
        shading, shadow = layer(est, "terrain", "shading_slope_deg"), layer(est, "terrain", "shadow_fraction")
        s_up = slope + (a.k * disc_max(sigma_s, footprint) if sigma_s is not None else 0.0)
        if shading is not None:
            s_up = s_up + a.weight * np.where(np.isfinite(shading), shading, 0.0)
        r_up = rough + (a.k * disc_max(sigma_r, footprint) if sigma_r is not None else 0.0)
        if residual is not None:
            r_up = np.maximum(r_up, disc_max(residual, footprint))
        certified = np.isfinite(s_up) & np.isfinite(r_up) & (s_up <= a.max_slope_deg) & (r_up <= a.max_roughness_m)
        if shadow is not None:
            certified &= ~(np.isfinite(shadow) & (shadow > a.max_shadow_fraction))
        shaded = np.isfinite(shading) & (shading > a.max_shading_slope_deg) if shading is not None else None
        clearance = disc(a.clearance_m / a.cell_m)
        hazard_near = ndimage.binary_dilation((true_slope > a.max_slope_deg) | (true_rough > a.max_roughness_m),
                                              structure=clearance)
        el = sun_deg(gt)
        b = bins[2] if el is None else bins[0] if el < a.low_sun_deg else bins[1]
        row = "%s (%s)" % (os.path.relpath(run), "n/a" if el is None else "%.1f" % el)
        for m in margins:
            ok = certified
            if shaded is not None:
                near = ndimage.binary_dilation(shaded, structure=disc(m / a.cell_m)) if m >= a.cell_m else shaded
                ok = certified & ~near
            # Clear by the clearance: every cell within it certified (outside the grid counts as not).
            sites = ndimage.binary_erosion(ok, structure=clearance, border_value=0)
            n, bad = int(sites.sum()), int((sites & hazard_near).sum())
            totals[(b, m)][0] += n
            totals[(b, m)][1] += bad
            row += "  m %g: %d / %d" % (m, n, bad)
        print(row)
    print("all %d maps:" % maps)
    for m in margins:
        line = "  m %g:" % m
        for b in bins:
            n, bad = totals[(b, m)]
            if n or b != bins[2]:
                line += "  %s: %d cells qualify, %d (%.2f %%) with a true hazard within %g m;" % (
                    b, n, bad, 100.0 * bad / max(1, n), a.clearance_m)
        n = sum(totals[(b, m)][0] for b in bins)
        bad = sum(totals[(b, m)][1] for b in bins)
        print(line + "  all: %d cells qualify, %d (%.2f %%)" % (n, bad, 100.0 * bad / max(1, n)))


if __name__ == "__main__":
    main()
