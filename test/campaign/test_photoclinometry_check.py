"""scripts/photoclinometry_check.py on a synthetic one-run campaign: long swells along the Sun's azimuth (16 m
wavelength, 12 deg slope amplitude) on Lambertian ground, three nadir images from 40 m (0.1 m per pixel), a map that
sees the swells halved (the truth smoothed by a 3 m Gaussian). With the Sun's azimuth as rendered the corrected slope
must come much closer to the truth; told the opposite azimuth (the brightness read with the wrong sign) it must get
worse; the written copy must hold the corrected slope, the rest linked; a map made with the shading tilt on is
refused. Also checks the navigation error is applied: the truth is moved by the run's error before scoring."""
import json
import math
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
import yaml
from PIL import Image
from scipy import ndimage

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "photoclinometry_check.py")
CELL, HALF = 0.5, 24.0
WAVELENGTH, AMPLITUDE_DEG, SUN_EL = 16.0, 12.0, 30.0
F, SIZE, HEIGHT = 400.0, 640, 40.0


def gradient_x(x):
    return math.tan(math.radians(AMPLITUDE_DEG)) * np.cos(2 * math.pi * x / WAVELENGTH)


def height(x):
    return math.tan(math.radians(AMPLITUDE_DEG)) * WAVELENGTH / (2 * math.pi) * np.sin(2 * math.pi * x / WAVELENGTH)


def slope_deg(z):
    gy, gx = np.gradient(z, CELL)
    return np.degrees(np.arctan(np.hypot(gx, gy)))


def write_tiff(path, a):
    Image.fromarray(a.astype(np.float32)).save(path)


def make_run(run, error_x_m, tilt_weight=None):
    ds = os.path.join(run, "dataset")
    os.makedirs(os.path.join(ds, "images"))
    os.makedirs(os.path.join(run, "terrain"))
    n = int(round(2 * HALF / CELL)) + 1
    x = -HALF + CELL * np.arange(n)
    X = np.tile(x, (n, 1))
    true_z = height(X)
    # The truth in the world; the map (and the images' poses) in the navigation's frame, shifted by +error_x_m:
    # the map's cell at x shows the ground at x - error_x_m.
    map_z = ndimage.gaussian_filter(height(X - error_x_m), 3.0 / CELL, mode="nearest")
    true_slope = ndimage.gaussian_filter(slope_deg(true_z), 0.5 / CELL)  # about a 4 m plane fit of these swells
    write_tiff(os.path.join(ds, "groundtruth_terrain_slope_deg.tiff"), true_slope)
    write_tiff(os.path.join(run, "terrain", "terrain_elevation_m.tiff"), map_z)
    write_tiff(os.path.join(run, "terrain", "terrain_slope_deg.tiff"), slope_deg(map_z))
    meta = {"geometry": {"x0_m": -HALF, "y0_m": -HALF, "cell_size_m": CELL, "cols": n, "rows": n}, "parameters": {}}
    if tilt_weight is not None:
        meta["parameters"]["shading_tilt_weight"] = tilt_weight
    with open(os.path.join(run, "terrain", "terrain.yaml"), "w") as f:
        yaml.safe_dump(meta, f)
    with open(os.path.join(ds, "camera.yaml"), "w") as f:
        yaml.safe_dump({"camera_matrix": {"data": [F, 0, SIZE / 2, 0, F, SIZE / 2, 0, 0, 1]},
                        "distortion_coefficients": {"data": [0, 0, 0, 0, 0]}}, f)
    with open(os.path.join(ds, "sequence.yaml"), "w") as f:
        yaml.safe_dump({"sun": {"elevation_deg": SUN_EL, "azimuth_deg": 90.0}}, f)
    e = math.radians(SUN_EL)
    sun = np.array([math.cos(e), 0.0, math.sin(e)])  # toward +x (azimuth 90 deg)
    u, v = np.meshgrid(np.arange(SIZE), np.arange(SIZE))
    stamps, poses = [], []
    for k, y0 in enumerate(np.linspace(-1.0, 1.0, 11)):
        # Nadir camera (optical x = world x, y = -world y, z = -world z: 180 deg about x), at the navigation's
        # x + error: the image shows the world's ground at (X_nav - error).
        gx = (u - SIZE / 2) / F * HEIGHT
        gy = y0 - (v - SIZE / 2) / F * HEIGHT
        g = gradient_x(gx)
        norm = np.sqrt(g * g + 1)
        value = 120.0 * np.maximum(0.0, (-g * sun[0] + sun[2]) / norm) / math.sin(e)
        Image.fromarray(np.clip(np.round(value), 0, 255).astype(np.uint8)).save(
            os.path.join(ds, "images", "%06d.png" % k))
        stamps.append(0.1 * k)
        poses.append("%.1f %.6f %.6f %.6f 1 0 0 0" % (0.1 * k, error_x_m, y0, HEIGHT))
    with open(os.path.join(ds, "times.txt"), "w") as f:
        f.write("\n".join("%.1f" % t for t in stamps) + "\n")
    with open(os.path.join(run, "trajectory.txt"), "w") as f:
        f.write("# t x y z qx qy qz qw\n" + "\n".join(poses) + "\n")
    with open(os.path.join(run, "t+000+000.json"), "w") as f:
        json.dump({"navigation_error_m": [error_x_m, 0.0, 0.0]}, f)


def run_tool(*args):
    return subprocess.run(["/usr/bin/python3", TOOL] + list(args), capture_output=True, text=True, timeout=300)


def rmse_line(stdout):
    for line in stdout.splitlines():
        if line.startswith("run_000"):
            before, after = line.split(":")[1].split("(")[0].split("/")
            return float(before), float(after)
    raise AssertionError(stdout)


class PhotoclinometryCheck(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="photoclinometry_check_")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def test_corrects_the_flattened_slope_with_the_right_sign(self):
        campaign = os.path.join(self.dir, "campaign")
        make_run(os.path.join(campaign, "runs", "run_000"), error_x_m=2.0)
        out = os.path.join(self.dir, "copy")
        done = run_tool(campaign, "--write", out, "--weight", "1")
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        before, after = rmse_line(done.stdout)
        self.assertIn("closer to the truth on 1 of 1 maps", done.stdout)
        # The default weight 0.5: half the map's gradient and half the shading's, which must add.
        done = run_tool(campaign)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        half = rmse_line(done.stdout)[1]
        print("map %.2f deg -> corrected %.2f deg (weight 1), %.2f deg (weight 0.5)" % (before, after, half))
        self.assertGreater(before, 2.5)
        self.assertLess(after, 0.4 * before)
        self.assertLess(half, 0.75 * before)
        # The copy: the corrected slope, the dataset linked.
        copy_run = os.path.join(out, "runs", "run_000")
        self.assertTrue(os.path.islink(os.path.join(copy_run, "dataset")))
        original = np.array(Image.open(os.path.join(campaign, "runs", "run_000", "terrain", "terrain_slope_deg.tiff")))
        corrected = np.array(Image.open(os.path.join(copy_run, "terrain", "terrain_slope_deg.tiff")))
        self.assertGreater(np.nanmax(np.abs(corrected - original)), 2.0)
        # Told the opposite Sun: the brightness is read with the wrong sign, and at weight 0.5 the two gradients
        # cancel: the slope gets worse than the map's.
        seq = os.path.join(campaign, "runs", "run_000", "dataset", "sequence.yaml")
        with open(seq, "w") as f:
            yaml.safe_dump({"sun": {"elevation_deg": SUN_EL, "azimuth_deg": 270.0}}, f)
        done = run_tool(campaign)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        wrong_before, wrong_after = rmse_line(done.stdout)
        self.assertAlmostEqual(wrong_before, before, places=2)
        self.assertGreater(wrong_after, before)

    def test_the_truth_is_moved_by_the_navigation_error(self):
        # The same run scored without its navigation error: the map's slope no longer lines up with the truth.
        campaign = os.path.join(self.dir, "campaign")
        run = os.path.join(campaign, "runs", "run_000")
        make_run(run, error_x_m=2.0)
        aligned = rmse_line(run_tool(campaign).stdout)[0]
        with open(os.path.join(run, "t+000+000.json"), "w") as f:
            json.dump({"navigation_error_m": [0.0, 0.0, 0.0]}, f)
        misaligned = rmse_line(run_tool(campaign).stdout)[0]
        self.assertGreater(misaligned, aligned + 1.0)

    def test_refuses_a_map_made_with_the_tilt_on(self):
        campaign = os.path.join(self.dir, "campaign")
        make_run(os.path.join(campaign, "runs", "run_000"), error_x_m=0.0, tilt_weight=0.5)
        done = run_tool(campaign)
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("shading tilt on", done.stdout + done.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
