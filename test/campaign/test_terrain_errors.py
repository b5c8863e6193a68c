"""scripts/terrain_errors.py against terrain_eval (docs/terrain/README.md): the rendered test descent's true terrain
taken as the "estimate" (its own TIFF layers, stated at a 4 m support), so that terrain_eval scores it against the
truth at that resolution, which it writes with --write-truth-at-resolution. The breakdown script reads those TIFFs
itself: its slope RMSE and hazard precision/recall must be terrain_eval's to the printed digits (one layer misread,
or the truth as sampled in place of the truth at the map's resolution, would not be: the latter gives 0.00 deg against
2.03), and its white-noise table must fall with the noise. The shading-relief report is checked with the true roughness
as the layer: it separates the truly rough cells from the truly safe ones perfectly (AUC 1, all flagged above 0.3 and
none of the safe), which a mixed-up mask or a reversed AUC would not.

scripts/slope_weight_check.py on a campaign-shaped folder whose one "map" is the descent's true slope flattened by 2
deg, with no slope sigma and a shading relief of 2 deg everywhere: with weight 1 the raised slope is the truth again,
so no qualifying cell may have a true slope above 10 deg within 3 m (a clearance disc that did not match the site
search's, or the shading not added, would leave some); with weight 0 the flattened slopes let such cells qualify, and
weight 2 qualifies fewer cells than weight 1.

scripts/site_risk_check.py on a synthetic campaign-shaped folder: four rocks whose true roughness is 0.4 m within 2 m
of them (the footprints that cover them) on a 3 deg plain; the map sees the plain exactly and no rock (roughness 0.05
m, no sigma), and its shading relief exceeds the limit only within 0.5 m of each rock (an RMS over the footprint,
diluted beyond). With a shading margin of 2 m the hazard covers 2 m around each rock, so no qualifying cell may have a
true hazard within 3 m (a margin or clearance disc not applied as the site search does would leave some); with 0 the
cells 3.5-5 m from a rock qualify with one, and 0 qualifies more cells than 2. The Sun's elevation (30 deg) puts
the map in the high-Sun bin."""
import json
import os
import numpy as np
import re
import shutil
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from campaign_test_util import env_or_exit  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "terrain_errors.py")
PYTHON = "/usr/bin/python3"


class TerrainErrors(unittest.TestCase):
    def test_agrees_with_terrain_eval_and_noise_lowers_precision(self):
        bin_dir = env_or_exit("PLANETARY_VO_BIN")
        dataset = env_or_exit("PLANETARY_VO_TEST_DATASET")
        out = env_or_exit("TERRAIN_ERRORS_TEST_OUTPUT")
        shutil.rmtree(out, ignore_errors=True)
        est = os.path.join(out, "estimate")
        os.makedirs(est)
        # The truth's grid file, renamed "terrain" and stating a 4 m plane-fit support (the map's resolution).
        with open(os.path.join(dataset, "groundtruth_terrain.yaml")) as f:
            text = f.read()
        for layer in ("elevation_m", "slope_deg", "roughness_m"):
            shutil.copy(os.path.join(dataset, f"groundtruth_terrain_{layer}.tiff"),
                        os.path.join(est, f"terrain_{layer}.tiff"))
            text = text.replace(f"groundtruth_terrain_{layer}.tiff", f"terrain_{layer}.tiff")
        text = text.replace("parameters:\n", "parameters:\n  support_radius_m: 4\n", 1)
        with open(os.path.join(est, "terrain.yaml"), "w") as f:
            f.write(text)
        score = os.path.join(out, "score.json")
        done = subprocess.run([os.path.join(bin_dir, "terrain_eval"), "--gt", dataset, "--est", est, "--json", score,
                               "--target-x-m", "0", "--target-y-m", "0"], capture_output=True, text=True, timeout=120)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        with open(score) as f:
            at_res = json.load(f)["at_map_resolution"]
        self.assertGreater(at_res["cells_surface"], 10000)
        self.assertGreater(at_res["slope_rmse_deg"], 0.1)  # the raw truth is not the truth seen at 4 m
        env = dict(os.environ, PLANETARY_VO_BUILD=os.path.dirname(os.path.dirname(os.path.dirname(
            bin_dir.rstrip("/")))))
        done = subprocess.run([PYTHON, TOOL, "--gt", dataset, "--est", est, "--work", os.path.join(out, "work")],
                              capture_output=True, text=True, timeout=300, env=env)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        printed = done.stdout
        self.assertTrue(os.path.isfile(os.path.join(out, "work", "truth_at_resolution.yaml")))
        cells = int(re.search(r"(\d+) cells with an estimated and a true slope", printed).group(1))
        self.assertEqual(cells, at_res["cells_surface"])
        rmse = float(re.search(r"slope RMSE ([0-9.]+) deg", printed).group(1))
        self.assertAlmostEqual(rmse, at_res["slope_rmse_deg"], delta=0.006)
        p, r = re.search(r"hazard precision ([0-9.]+), recall ([0-9.]+) \(this map\)", printed).groups()
        self.assertAlmostEqual(float(p), at_res["hazard_precision"], delta=0.0006)
        self.assertAlmostEqual(float(r), at_res["hazard_recall"], delta=0.0006)
        noise = [float(x) for x in re.findall(r"sigma [0-9.]+ deg: precision ([0-9.]+)", printed)]
        self.assertEqual(len(noise), 6)
        self.assertGreater(noise[0], noise[-1] + 0.1, printed)  # 0.25 deg of noise against 2 deg
        self.assertNotIn("shading relief", printed)  # no layer, no report

        # The true roughness as the shading layer: a perfect separator at the roughness threshold.
        shutil.copy(os.path.join(dataset, "groundtruth_terrain_roughness_m.tiff"),
                    os.path.join(est, "terrain_shading_slope_deg.tiff"))
        done = subprocess.run([PYTHON, TOOL, "--gt", dataset, "--est", est, "--work", os.path.join(out, "work"),
                               "--shading-thresholds", "0.3"], capture_output=True, text=True, timeout=300, env=env)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        printed = done.stdout
        rough, safe = (int(x) for x in re.search(r"truly rough \(> 0.3 m\) (\d+), truly safe (\d+)", printed).groups())
        self.assertGreater(rough, 0, printed)
        self.assertGreater(safe, 0, printed)
        self.assertIn("ROC AUC rough vs safe 1.000", printed)
        self.assertIn("above 0.3 deg: rough 1.000, safe 0.000", printed)


    def test_slope_weight_check_counts_the_steep_cells_the_flattened_slope_lets_through(self):
        dataset = env_or_exit("PLANETARY_VO_TEST_DATASET")
        out = os.path.join(env_or_exit("TERRAIN_ERRORS_TEST_OUTPUT"), "weights")
        sys.path.insert(0, os.path.join(ROOT, "scripts"))
        from terrain_errors import read_tiff
        from PIL import Image
        shutil.rmtree(out, ignore_errors=True)
        run = os.path.join(out, "runs", "run_000")
        os.makedirs(os.path.join(run, "dataset"))
        os.makedirs(os.path.join(run, "terrain"))
        truth_path = os.path.join(dataset, "groundtruth_terrain_slope_deg.tiff")
        shutil.copy(truth_path, os.path.join(run, "dataset", "groundtruth_terrain_slope_deg.tiff"))
        truth = read_tiff(truth_path).astype(np.float32)
        self.assertGreater(int(np.sum(truth > 10.0)), 100)  # the descent's terrain has steep cells
        layers = {"slope_deg": truth - 2.0, "slope_sigma_deg": np.zeros_like(truth),
                  "shading_slope_deg": np.full_like(truth, 2.0)}
        for name, value in layers.items():
            Image.fromarray(value.astype(np.float32), mode="F").save(
                os.path.join(run, "terrain", "terrain_%s.tiff" % name))
        done = subprocess.run([PYTHON, os.path.join(ROOT, "scripts", "slope_weight_check.py"), out,
                               "--weights", "0,1,2"], capture_output=True, text=True, timeout=300)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        counts = {float(w): (int(n), int(bad)) for w, n, bad in re.findall(
            r"w ([0-9.]+): (\d+) cells qualify, (\d+) \(", done.stdout)}
        self.assertEqual(sorted(counts), [0.0, 1.0, 2.0], done.stdout)
        self.assertGreater(counts[1.0][0], 0, done.stdout)
        self.assertEqual(counts[1.0][1], 0, done.stdout)
        self.assertGreater(counts[0.0][1], 0, done.stdout)
        self.assertGreater(counts[0.0][0], counts[1.0][0], done.stdout)
        self.assertLess(counts[2.0][0], counts[1.0][0], done.stdout)

    def test_site_risk_check_counts_the_hazards_a_diluted_shading_lets_through(self):
        from PIL import Image
        out = os.path.join(env_or_exit("TERRAIN_ERRORS_TEST_OUTPUT"), "risk")
        shutil.rmtree(out, ignore_errors=True)
        run = os.path.join(out, "runs", "run_000")
        os.makedirs(os.path.join(run, "dataset"))
        os.makedirs(os.path.join(run, "terrain"))
        cell, n = 0.5, 161
        y, x = (np.mgrid[0:n, 0:n] - n // 2) * cell
        rocks = [(-20.0, -20.0), (20.0, -15.0), (-10.0, 18.0), (15.0, 20.0)]
        distance = np.min([np.hypot(x - rx, y - ry) for rx, ry in rocks], axis=0)
        truth = {"slope_deg": np.full((n, n), 3.0), "roughness_m": np.where(distance <= 2.0, 0.4, 0.05)}
        est = {"slope_deg": np.full((n, n), 3.0), "roughness_m": np.full((n, n), 0.05),
               "slope_sigma_deg": np.zeros((n, n)), "relief_sigma_m": np.zeros((n, n)),
               "shading_slope_deg": np.where(distance <= 0.5, 4.0, 1.0)}
        for folder, prefix, layers in ((os.path.join(run, "dataset"), "groundtruth_terrain", truth),
                                       (os.path.join(run, "terrain"), "terrain", est)):
            for name, value in layers.items():
                Image.fromarray(value.astype(np.float32), mode="F").save(
                    os.path.join(folder, "%s_%s.tiff" % (prefix, name)))
        with open(os.path.join(run, "dataset", "sequence.yaml"), "w") as f:
            f.write("sun:\n  elevation_deg: 30.0\n  azimuth_deg: 100.0\n")
        done = subprocess.run([PYTHON, os.path.join(ROOT, "scripts", "site_risk_check.py"), out,
                               "--margins", "0,2"], capture_output=True, text=True, timeout=300)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        counts = {float(m): (int(q), int(bad)) for m, q, bad in re.findall(
            r"m ([0-9.]+):  Sun < 15 deg: 0 cells qualify, 0 \(0.00 %\) with a true hazard within 3 m;  "
            r"Sun >= 15 deg: (\d+) cells qualify, (\d+) \(", done.stdout)}
        self.assertEqual(sorted(counts), [0.0, 2.0], done.stdout)
        self.assertGreater(counts[2.0][0], 1000, done.stdout)
        self.assertEqual(counts[2.0][1], 0, done.stdout)
        self.assertGreater(counts[0.0][1], 100, done.stdout)
        self.assertGreater(counts[0.0][0], counts[2.0][0], done.stdout)

    def test_shading_calibration_reads_the_band_relief_of_a_known_surface(self):
        """A sinusoid of 8 m wavelength (inside the 0.5-2 m band's transfer): its RMS slope through the band is
        known in closed form; a map reading it exactly has ratio 1, one reading 0.6 of it has 0.6."""
        from PIL import Image
        out = os.path.join(env_or_exit("TERRAIN_ERRORS_TEST_OUTPUT"), "calibration")
        shutil.rmtree(out, ignore_errors=True)
        cell, n, wavelength, amplitude = 0.5, 161, 8.0, 0.3
        x = (np.arange(n) - n // 2) * cell
        elevation = np.tile(amplitude * np.sin(2 * np.pi * x / wavelength), (n, 1))
        # RMS slope of a sinusoid: amplitude * k / sqrt(2); the band's transfer at the wavelength: the difference
        # of the two Gaussians' responses; central differences on 0.5 m cells: sin(k h) / (k h).
        k = 2 * np.pi / wavelength
        transfer = np.exp(-0.5 * (k * 0.5) ** 2) - np.exp(-0.5 * (k * 2.0) ** 2)
        expected_deg = np.degrees(amplitude * k / np.sqrt(2) * transfer * np.sin(k * cell) / (k * cell))
        for run, sun, factor in (("run_000", 10.0, 1.0), ("run_001", 30.0, 0.6)):
            os.makedirs(os.path.join(out, "runs", run, "dataset"))
            os.makedirs(os.path.join(out, "runs", run, "terrain"))
            Image.fromarray(elevation.astype(np.float32), mode="F").save(
                os.path.join(out, "runs", run, "dataset", "groundtruth_terrain_elevation_m.tiff"))
            reading = np.full((n, n), factor * expected_deg, dtype=np.float32)
            reading[:, : n // 3] = np.nan  # part of the map not read
            Image.fromarray(reading, mode="F").save(
                os.path.join(out, "runs", run, "terrain", "terrain_shading_slope_deg.tiff"))
            with open(os.path.join(out, "runs", run, "dataset", "sequence.yaml"), "w") as f:
                f.write("sun:\n  elevation_deg: %g\n  azimuth_deg: 100.0\n" % sun)
            # The map's ground: a valley along y, rising 5 deg on both sides. With the Sun toward +x (azimuth
            # 100), the side x > 0 is turned away from it. The true hazards (slope 12 deg) are all there, x > 5 m.
            map_z = (np.abs(np.tile(x, (n, 1))) * np.tan(np.radians(5.0))).astype(np.float32)
            Image.fromarray(map_z, mode="F").save(os.path.join(out, "runs", run, "terrain", "terrain_elevation_m.tiff"))
            true_slope = np.where(np.tile(x, (n, 1)) > 5.0, 12.0, 2.0).astype(np.float32)
            Image.fromarray(true_slope, mode="F").save(
                os.path.join(out, "runs", run, "dataset", "groundtruth_terrain_slope_deg.tiff"))
            Image.fromarray(np.full((n, n), 0.05, dtype=np.float32), mode="F").save(
                os.path.join(out, "runs", run, "dataset", "groundtruth_terrain_roughness_m.tiff"))
        done = subprocess.run([PYTHON, os.path.join(ROOT, "scripts", "shading_calibration.py"), out],
                              capture_output=True, text=True, timeout=300)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        ratios = {float(sun): float(r) for sun, r in re.findall(r"run_00\d \(([0-9.]+)\): \d+ cells, [0-9.]+ / "
                                                                r"[0-9.]+, ratio ([0-9.]+)", done.stdout)}
        self.assertAlmostEqual(ratios.get(10.0, 0.0), 1.0, delta=0.05, msg=done.stdout)
        self.assertAlmostEqual(ratios.get(30.0, 0.0), 0.6, delta=0.03, msg=done.stdout)
        self.assertIn("Sun < 15 deg: 1 maps, ratio median 1.0", done.stdout)
        self.assertIn("Sun >= 15 deg: 1 maps, ratio median 0.6", done.stdout)
        # Read cells: x > -13.25 m (the first third unread). Hazards: x > 5 m, all turned away. Safe: turned away
        # for 0 < x <= 5 m (the central differences over +-2 m still rise there; at x = 0 the ground is level).
        away = re.findall(r"ground turned away from the Sun: ([0-9.]+) of (\d+) hazardous cells, ([0-9.]+) of (\d+) "
                          r"safe", done.stdout)
        self.assertEqual(len(away), 4, done.stdout)  # two maps, two Sun bins
        cols_read = n - n // 3
        cols_hazard = int(np.sum(x > 5.0))
        cols_safe_away = int(np.sum((x > 0.0) & (x <= 5.0)))
        for share_hazard, hazards, share_safe, safe in away:
            self.assertEqual(int(hazards), n * cols_hazard, done.stdout)
            self.assertEqual(int(safe), n * (cols_read - cols_hazard), done.stdout)
            self.assertAlmostEqual(float(share_hazard), 1.0, delta=0.005, msg=done.stdout)
            self.assertAlmostEqual(float(share_safe), cols_safe_away / (cols_read - cols_hazard), delta=0.006,
                                   msg=done.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
