#!/usr/bin/python3
"""Signed photoclinometry at the footprint's scale (issue 11, docs/terrain/README.md, Next item 1): does the
brightness of a footprint-sized patch against its surroundings correct the slope that the map's plane fit
flattens? An offline measurement on a campaign's maps, before any change to the terrain model.

Per run of a scripts/hazard_campaign.py --keep-images campaign (runs/run_*/dataset with images, sequence.yaml, the
true terrain; runs/run_*/terrain the map; runs/run_*/trajectory.txt the navigation; runs/run_*/t*.json its
terrain_eval results with `navigation_error_m`):
  1. Every 5th image whose pixel covers at most 0.25 m of ground (from the estimated pose's height over the map) is
     projected onto the map's own elevation with the estimated pose (pinhole + the camera's k1, k2), after a blur to
     about 0.25 m; the mean over the images is an orthoimage on the map's cells. Nothing from the truth.
  2. rel = G(ortho, --footprint-sigma-m) / G(ortho, --surround-sigma-m) - 1 (normalised Gaussians over the seen
     cells). Lambert: a facet tilted toward the Sun by t (relative to its surroundings) under a Sun at elevation e is
     brighter by about t / tan(e), so -rel * tan(e) is the gradient of the ground along the Sun's azimuth relative to
     its surroundings (brighter = descending toward the Sun).
  3. The map's gradient along the Sun's azimuth (its elevation smoothed at the footprint's sigma) is replaced by
     (1 - w) of itself plus w times (the map's gradient at the surround's sigma + the photoclinometric one); the
     component across the Sun is kept. The map's slope layer gets the difference between the two slopes so formed.
  4. Printed per run: the slope RMSE against the truth in the navigation's frame (the truth moved by the navigation's
     error at the end of the run, as terrain_eval's "at touchdown"; the truth is used only here) on the map's cells,
     of the map's slope and the corrected one. --write DIR writes a copy of the campaign with the corrected slope
     layers (the rest linked) for scripts/site_risk_check.py.

  /usr/bin/python3 scripts/photoclinometry_check.py CAMPAIGN_DIR [--write DIR] [--footprint-sigma-m 1]
        [--surround-sigma-m 6] [--weight 0.5]

Needs numpy, scipy, PIL and yaml. The maps must be made with the shading tilt off (`shading_tilt: {weight: 0}`
in the hazard config; it is on by default since session 27), else the slope would be corrected twice: refused.
"""
import argparse
import glob
import math
import os
import shutil
import sys

import numpy as np
import yaml
from PIL import Image
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from site_risk_check import in_navigation_frame, navigation_error  # noqa: E402  (as terrain_eval's touchdown)

MAX_PIXEL_M = 0.25  # as the shading relief's max_pixel_footprint_m (terrain/shading_relief.h)
IMAGE_STEP = 5


def tiff(path):
    return np.array(Image.open(path), dtype=np.float64)


def rotation(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def blur(grid, sigma_m, cell_m):
    """Gaussian over the known cells only (normalised); NaN where less than half of the weight is known."""
    known = np.isfinite(grid)
    num = ndimage.gaussian_filter(np.where(known, grid, 0.0), sigma_m / cell_m)
    den = ndimage.gaussian_filter(known.astype(float), sigma_m / cell_m)
    return np.where(den > 0.5, num / np.maximum(den, 1e-9), np.nan)


def orthoimage(run, elevation, geometry):
    """The mean brightness of each known map cell over the images that resolve it (estimated poses)."""
    dataset = os.path.join(run, "dataset")
    with open(os.path.join(dataset, "camera.yaml")) as f:
        cam = yaml.safe_load(f)
    K = np.array(cam["camera_matrix"]["data"]).reshape(3, 3)
    dist = list(cam.get("distortion_coefficients", {}).get("data", [0, 0])) + [0, 0]
    poses = np.loadtxt(os.path.join(run, "trajectory.txt"), ndmin=2)
    stamps = np.loadtxt(os.path.join(dataset, "times.txt"), ndmin=1)
    x0, y0, cell = geometry
    rows, cols = elevation.shape
    known = np.isfinite(elevation)
    r_idx, c_idx = np.nonzero(known)
    points = np.stack([x0 + cell * c_idx, y0 + cell * r_idx, elevation[known]], -1)
    total, count = np.zeros(len(points)), np.zeros(len(points))
    ground = np.nanmedian(elevation)
    for pose in poses[::IMAGE_STEP]:
        t, R = pose[1:4], rotation(pose[4:8])
        pixel_m = (t[2] - ground) / K[0, 0]
        if not (0 < pixel_m <= MAX_PIXEL_M):
            continue
        frame = int(np.argmin(np.abs(stamps - pose[0])))
        image = np.array(Image.open(os.path.join(dataset, "images", "%06d.png" % frame)), dtype=np.float64)
        image = ndimage.gaussian_filter(image, MAX_PIXEL_M / pixel_m)
        p = (points - t) @ R
        z = p[:, 2]
        a, b = p[:, 0] / np.where(z > 0, z, 1), p[:, 1] / np.where(z > 0, z, 1)
        r2 = a * a + b * b
        f = 1 + dist[0] * r2 + dist[1] * r2 * r2
        u, v = K[0, 0] * a * f + K[0, 2], K[1, 1] * b * f + K[1, 2]
        ok = (z > 0) & (u > 1) & (v > 1) & (u < image.shape[1] - 2) & (v < image.shape[0] - 2)
        total[ok] += ndimage.map_coordinates(image, [v[ok], u[ok]], order=1)
        count[ok] += 1
    ortho = np.full(elevation.shape, np.nan)
    ortho[known] = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    ortho[ortho < 3] = np.nan  # black: shadow, no shading to read
    return ortho


def corrected_slope(run, footprint_sigma_m, surround_sigma_m, weight):
    """(map slope, corrected slope, Sun elevation deg) of one run; None when it has no map or pose."""
    terrain = os.path.join(run, "terrain")
    with open(os.path.join(terrain, "terrain.yaml")) as f:
        meta = yaml.safe_load(f)
    if (meta.get("parameters") or {}).get("shading_tilt_weight", 0) > 0:
        sys.exit("photoclinometry_check: %s was mapped with the shading tilt on (its slope is corrected already); "
                 "measure on maps made with shading_tilt.weight 0" % terrain)
    g = meta["geometry"]
    geometry = (g["x0_m"], g["y0_m"], g["cell_size_m"])
    elevation = tiff(os.path.join(terrain, "terrain_elevation_m.tiff"))
    slope = tiff(os.path.join(terrain, "terrain_slope_deg.tiff"))
    with open(os.path.join(run, "dataset", "sequence.yaml")) as f:
        sun = yaml.safe_load(f)["sun"]
    e, az = math.radians(sun["elevation_deg"]), math.radians(sun["azimuth_deg"])
    to_sun = (math.sin(az), math.cos(az))  # world x, y (azimuth from +y toward +x)
    ortho = orthoimage(run, elevation, geometry)
    cell = geometry[2]
    rel = blur(ortho, footprint_sigma_m, cell) / blur(ortho, surround_sigma_m, cell) - 1.0
    along_shading = -rel * math.tan(e)

    def gradient(sigma_m):
        gy, gx = np.gradient(blur(elevation, sigma_m, cell), cell)
        return gx * to_sun[0] + gy * to_sun[1], -gx * to_sun[1] + gy * to_sun[0]

    along, across = gradient(footprint_sigma_m)
    along_surround, _ = gradient(surround_sigma_m)
    along_new = (1.0 - weight) * along + weight * (along_surround + along_shading)
    own = np.degrees(np.arctan(np.hypot(along, across)))
    new = np.degrees(np.arctan(np.hypot(along_new, across)))
    delta = np.where(np.isfinite(new - own), new - own, 0.0)
    return slope, slope + delta, sun["elevation_deg"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("campaign")
    ap.add_argument("--write", default="", metavar="DIR")
    ap.add_argument("--footprint-sigma-m", type=float, default=1.0)
    ap.add_argument("--surround-sigma-m", type=float, default=6.0)
    ap.add_argument("--weight", type=float, default=0.5)
    a = ap.parse_args()
    runs = sorted(glob.glob(os.path.join(a.campaign, "runs", "run_*")))
    if not runs:
        sys.exit("photoclinometry_check: no runs/run_* in %s" % a.campaign)
    print("run (Sun deg): slope RMSE against the truth in the navigation's frame, map / corrected (deg), cells")
    better = judged = 0
    for run in runs:
        name = os.path.basename(run)
        error = navigation_error(run)
        if error is None or not os.path.isdir(os.path.join(run, "dataset", "images")):
            print("%s: no navigation error or no images; left out" % name)
            continue
        slope, new, sun = corrected_slope(run, a.footprint_sigma_m, a.surround_sigma_m, a.weight)
        true_slope = in_navigation_frame(
            tiff(os.path.join(run, "dataset", "groundtruth_terrain_slope_deg.tiff")), error, 0.5)
        m = np.isfinite(slope) & np.isfinite(true_slope)
        if m.sum() == 0:
            print("%s (%.1f): no map cells" % (name, sun))
        else:
            r0 = math.sqrt(np.mean((slope[m] - true_slope[m]) ** 2))
            r1 = math.sqrt(np.mean((new[m] - true_slope[m]) ** 2))
            judged += 1
            better += r1 < r0
            print("%s (%.1f): %.2f / %.2f (%d)" % (name, sun, r0, r1, m.sum()))
        if a.write:
            out = os.path.join(a.write, "runs", name)
            os.makedirs(out, exist_ok=True)
            for f in ["dataset", "trajectory.txt"] + [os.path.basename(p) for p in glob.glob(os.path.join(run, "t*.json"))]:
                if not os.path.lexists(os.path.join(out, f)):
                    os.symlink(os.path.realpath(os.path.join(run, f)), os.path.join(out, f))
            shutil.rmtree(os.path.join(out, "terrain"), ignore_errors=True)
            shutil.copytree(os.path.join(run, "terrain"), os.path.join(out, "terrain"))
            Image.fromarray(new.astype(np.float32)).save(os.path.join(out, "terrain", "terrain_slope_deg.tiff"))
    print("corrected slope closer to the truth on %d of %d maps" % (better, judged))


if __name__ == "__main__":
    main()
