#!/usr/bin/python3
"""How the hazard map's shading relief (terrain/shading_relief.h, layer shading_slope_deg) compares with the true relief
it measures, per map, split by the Sun's elevation (issue 11).

The shading relief is the RMS slope of the relief between band_min_m and band_max_m (Gaussian sigmas) over the
lander's footprint disc, read from the keyframes' shading. The same quantity is computed here from the true elevation
of the landing area (groundtruth_terrain_elevation_m): the difference of the elevation blurred at the two sigmas, its
gradient by central differences, its squared magnitude averaged over the footprint disc, the root in degrees. Per
map: the ratio of the medians (reading / truth) over the cells where both are known, and their correlation; per Sun
bin: the median and interquartile range of the ratios over the maps. A reading whose normalisation is right has the
same ratio at every Sun and on every map (below 1: the truth goes through the same band, so not the band; the
images' blur and the photometry are candidates); a spread between maps is an error the hazard threshold cannot
absorb.

Where the Sun's azimuth is in sequence.yaml, it also prints, per map and per Sun bin, the share of the read cells
whose ground (the map's elevation: its central differences over the footprint's radius, as
ShadingRelief::localSunElevationDeg) is turned away from the Sun, i.e. sees it lower than level ground does, for the
truly hazardous cells (true slope above --max-slope-deg or roughness above --max-roughness-m) and for the safe ones.
There the normalisation lowers the reading, so a larger share on hazards than on safe ground means the
normalisation takes relief away where it matters (docs/terrain/README.md, Next item 8).

  /usr/bin/python3 scripts/shading_calibration.py CAMPAIGN_DIR [CAMPAIGN_DIR ...] [--band-min-m 0.5]
        [--band-max-m 2] [--footprint-m 4] [--cell-m 0.5] [--low-sun-deg 15] [--min-cells 500]
        [--max-slope-deg 10] [--max-roughness-m 0.3]

CAMPAIGN_DIR: a scripts/hazard_campaign.py --runs output folder (runs/run_*/dataset with the true terrain and
sequence.yaml, runs/run_*/terrain with the map). Needs numpy, scipy and yaml.
"""
import argparse
import glob
import os
import sys

import numpy as np
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from site_risk_check import sun_deg  # noqa: E402
from slope_weight_check import disc, layer  # noqa: E402


def true_band_slope_deg(elevation_m, cell_m, band_min_m, band_max_m, footprint_m):
    """RMS slope (deg) of the true relief between the two Gaussian sigmas over each cell's footprint disc."""
    known = np.isfinite(elevation_m)
    z = np.where(known, elevation_m, np.nanmean(elevation_m))
    band = ndimage.gaussian_filter(z, band_min_m / cell_m) - ndimage.gaussian_filter(z, band_max_m / cell_m)
    gy, gx = np.gradient(band, cell_m)
    footprint = disc(0.5 * footprint_m / cell_m).astype(float)
    footprint /= footprint.sum()
    mean_square = ndimage.convolve(gx * gx + gy * gy, footprint, mode="nearest")
    return np.where(known, np.degrees(np.sqrt(mean_square)), np.nan)


def map_ground_sun_deg(elevation_m, cell_m, sun_elevation, sun_azimuth, radius_m):
    """The Sun's elevation (deg) over the ground of each cell: the plane whose gradient is the elevation's central
    difference over +-radius_m in x (columns) and y (rows), one-sided where one end is unknown, 0 where both are;
    NaN where the elevation is unknown. The azimuth is measured from +y toward +x."""
    k = max(1, int(round(radius_m / cell_m)))
    step = k * cell_m
    z = np.pad(elevation_m.astype(float), k, constant_values=np.nan)
    rows, cols = elevation_m.shape

    def at(dr, dc):
        return z[k + dr:k + dr + rows, k + dc:k + dc + cols]

    def gradient(minus, centre, plus):
        with np.errstate(invalid="ignore"):
            return np.where(np.isfinite(minus) & np.isfinite(plus), (plus - minus) / (2 * step),
                            np.where(np.isfinite(plus), (plus - centre) / step,
                                     np.where(np.isfinite(minus), (centre - minus) / step, 0.0)))

    centre = at(0, 0)
    gx, gy = gradient(at(0, -k), centre, at(0, k)), gradient(at(-k, 0), centre, at(k, 0))
    e, a = np.radians(sun_elevation), np.radians(sun_azimuth)
    sun = (np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), np.sin(e))
    sine = (-gx * sun[0] - gy * sun[1] + sun[2]) / np.sqrt(gx * gx + gy * gy + 1.0)
    return np.where(np.isfinite(centre), np.degrees(np.arcsin(np.clip(sine, -1.0, 1.0))), np.nan)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("campaigns", nargs="+")
    ap.add_argument("--band-min-m", type=float, default=0.5, help="shading.band_min_m (config/hazard.yaml)")
    ap.add_argument("--band-max-m", type=float, default=2.0, help="shading.band_max_m")
    ap.add_argument("--footprint-m", type=float, default=4.0)
    ap.add_argument("--cell-m", type=float, default=0.5, help="the landing area's cell size")
    ap.add_argument("--low-sun-deg", type=float, default=15.0)
    ap.add_argument("--min-cells", type=int, default=500, help="maps with fewer cells read are left out")
    ap.add_argument("--max-slope-deg", type=float, default=10.0, help="a true hazard's slope (thresholds)")
    ap.add_argument("--max-roughness-m", type=float, default=0.3, help="a true hazard's roughness (thresholds)")
    a = ap.parse_args()
    runs = sorted(r for c in a.campaigns for r in glob.glob(os.path.join(c, "runs", "run_*")))
    rows = []
    away = []  # (Sun elevation, hazard cells, of them turned away, safe cells, of them turned away)
    print("run (Sun deg): cells, median reading / median truth (deg), ratio, correlation")
    for run in runs:
        est, gt = os.path.join(run, "terrain"), os.path.join(run, "dataset")
        reading = layer(est, "terrain", "shading_slope_deg")
        elevation = layer(gt, "groundtruth_terrain", "elevation_m")
        el = sun_deg(gt)
        if reading is None or elevation is None or el is None:
            continue
        truth = true_band_slope_deg(elevation, a.cell_m, a.band_min_m, a.band_max_m, a.footprint_m)
        ok = np.isfinite(reading) & np.isfinite(truth)
        if ok.sum() < a.min_cells:
            continue
        r, t = reading[ok], truth[ok]
        ratio = float(np.median(r) / np.median(t))
        corr = float(np.corrcoef(r, t)[0, 1]) if r.std() > 0 and t.std() > 0 else float("nan")
        rows.append((el, ratio))
        print("%s (%.1f): %d cells, %.2f / %.2f, ratio %.2f, correlation %.2f"
              % (os.path.relpath(run), el, ok.sum(), np.median(r), np.median(t), ratio, corr))
        az, map_z = sun_deg(gt, "azimuth_deg"), layer(est, "terrain", "elevation_m")
        true_slope, true_rough = layer(gt, "groundtruth_terrain", "slope_deg"), layer(gt, "groundtruth_terrain",
                                                                                     "roughness_m")
        if az is None or map_z is None or true_slope is None or true_rough is None:
            continue
        ground = map_ground_sun_deg(map_z, a.cell_m, el, az, 0.5 * a.footprint_m)
        read = np.isfinite(reading) & np.isfinite(ground) & np.isfinite(true_slope) & np.isfinite(true_rough)
        with np.errstate(invalid="ignore"):
            hazard = (true_slope > a.max_slope_deg) | (true_rough > a.max_roughness_m)
            turned_away = ground < el - 1e-6  # deg: level ground is not turned away
        counts = (int((read & hazard).sum()), int((read & hazard & turned_away).sum()),
                  int((read & ~hazard).sum()), int((read & ~hazard & turned_away).sum()))
        away.append((el,) + counts)
        print("    ground turned away from the Sun: %s of %d hazardous cells, %s of %d safe"
              % ("%.2f" % (counts[1] / counts[0]) if counts[0] else "-", counts[0],
                 "%.2f" % (counts[3] / counts[2]) if counts[2] else "-", counts[2]))
    print("all %d maps:" % len(rows))
    for name, keep in (("Sun < %g deg" % a.low_sun_deg, lambda e: e < a.low_sun_deg),
                       ("Sun >= %g deg" % a.low_sun_deg, lambda e: e >= a.low_sun_deg)):
        ratios = [ratio for el, ratio in rows if keep(el)]
        if ratios:
            q1, med, q3 = np.percentile(ratios, [25, 50, 75])
            print("  %s: %d maps, ratio median %.2f, interquartile %.2f-%.2f" % (name, len(ratios), med, q1, q3))
        else:
            print("  %s: no map" % name)
        sums = np.sum([c[1:] for c in away if keep(c[0])], axis=0) if any(keep(c[0]) for c in away) else None
        if sums is not None and sums[0] and sums[2]:
            print("    ground turned away from the Sun: %.2f of %d hazardous cells, %.2f of %d safe"
                  % (sums[1] / sums[0], sums[0], sums[3] / sums[2], sums[2]))
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
