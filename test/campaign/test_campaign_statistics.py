#!/usr/bin/python3
"""Statistics, gathering, dispersion draws and run classification of scripts/vo_campaign.py on synthetic data
with known answers (no tool is run)."""
import math
import os
import shutil
import statistics
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import campaign_test_util as util  # noqa: E402

vc = util.load_tool()

N_OK = 100  # ok runs k = 0..99 with final position error k + 1 m


def make_plan(out_dir, n_runs, configs=("a",)):
    disp = {"terrain_seed": None, "sensor_seed": None, "dems": ["apollo15_gld100"], "placement_ranks": [0, 3],
            "sun_elevation_deg": [5.0, 45.0], "sun_azimuth_deg": [0.0, 360.0], "init_position_sigma_m": 10.0,
            "init_attitude_sigma_deg": 0.05, "init_scale_sigma_percent": 1.0}
    runs = []
    for k in range(n_runs):
        run_id = f"run_{k:03d}"
        runs.append({"id": run_id, "index": k, "dir": os.path.join(out_dir, "runs", run_id),
                     "params": vc.draw_run_params(disp, 1, k), "commands": {"render": [], "configs": {}}})
    return {"format": vc.PLAN_FORMAT, "name": "synthetic", "command": [vc.PYTHON, vc.SCRIPT], "git": None,
            "output": out_dir, "bin": "/nonexistent", "sequence": "approach_down", "size_px": 64,
            "duration_s": 1.0, "sensors": "flight", "seed": 1, "configs": [{"name": c, "path": "/x.yaml"}
                                                                          for c in configs],
            "dispersions": disp, "not_applied": [], "eval": {}, "runs": runs}


def write_result(plan, k, config, status, final, series, vo_wall=1.0):
    run = plan["runs"][k]
    d = os.path.join(run["dir"], config)
    os.makedirs(d, exist_ok=True)
    result = {"format": vc.RESULT_FORMAT, "campaign": plan["name"], "run_id": run["id"], "index": k,
              "config": config, "params": run["params"], "status": status,
              "reason": "" if status == "ok" else "x",
              "vo": {}, "final": dict({m[0]: None for m in vc.METRICS}, **final), "series": series,
              "timing": {"render_wall_s": 2.0, "render_cpu_s": 1.5, "render_cached": False,
                         "render_threads": 1, "vo_wall_s": vo_wall, "vo_cpu_s": 0.5, "eval_wall_s": 0.1,
                         "eval_cpu_s": 0.1},
              "executor": {}}
    vc.write_json(os.path.join(d, "result.json"), result)


class Statistics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="campaign_stats_")
        # 100 ok runs + 3 lost + 2 diverged + 1 without a result file = 106 runs.
        cls.plan = plan = make_plan(cls.tmp, N_OK + 6)
        for k in range(N_OK):
            v = float(k + 1)
            # Half of the runs sampled on 0, 0.1, ..., 1.0 s, the other half on 0.05, 0.15, ..., 0.95 s:
            # errors linear in time, so the resampling on the common grid is exact and the mean at t is
            # 50.5 t.
            offset = 0.0 if k % 2 == 0 else 0.05
            t = [round(offset + 0.1 * i, 10) for i in range(11 if offset == 0.0 else 10)]
            sign = 1.0 if k % 2 == 0 else -1.0
            series = {"t_rel_s": t, "position_error_m": [v * x for x in t],
                      "scale_error_percent": [sign * v * x for x in t]}
            write_result(plan, k, "a", "ok", {"position_error_m": v, "scale_error_percent": sign * v,
                                              "sim3_ate_percent": v / 100.0}, series)
        for k in range(N_OK, N_OK + 3):
            write_result(plan, k, "a", "lost", {}, {})
        for k, err in ((N_OK + 3, 1000.0), (N_OK + 4, 2000.0)):
            write_result(plan, k, "a", "diverged", {"position_error_m": err, "sim3_ate_percent": 9.0},
                         {"t_rel_s": [0.0, 1.0], "position_error_m": [0.0, err]})
        # run N_OK + 5 has no result file.
        cls.summary = vc.write_report(plan, cls.tmp, {"scheduler": "local", "wall_s": 12.0})
        cls.cs = cls.summary["configs"]["a"]

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_final_statistics_over_ok_runs(self):
        s = self.cs["final"]["position_error_m"]
        self.assertEqual(s["n"], N_OK)  # the diverged runs' 1000 m and 2000 m are not in the statistics
        self.assertAlmostEqual(s["mean"], 50.5, places=12)
        # Sample standard deviation of 1..100: sqrt(100 * 101 / 12).
        self.assertAlmostEqual(s["std"], math.sqrt(100 * 101 / 12), places=10)
        self.assertAlmostEqual(s["bound_3sigma"], 50.5 + 3 * math.sqrt(100 * 101 / 12), places=10)
        # numpy's linear p99 of 1..100: rank 0.99 * 99 = 98.01 -> 99 + 0.01 * (100 - 99).
        self.assertAlmostEqual(s["p99"], 99.01, places=10)
        self.assertEqual(s["max"], 100.0)

    def test_signed_error_bound_uses_magnitude(self):
        s = self.cs["final"]["scale_error_percent"]
        values = [(1.0 if k % 2 == 0 else -1.0) * (k + 1) for k in range(N_OK)]
        self.assertAlmostEqual(s["mean"], statistics.mean(values), places=12)  # -0.5: signed mean
        self.assertAlmostEqual(s["std"], statistics.stdev(values), places=10)
        self.assertAlmostEqual(s["bound_3sigma"], abs(statistics.mean(values)) + 3 * statistics.stdev(values),
                               places=10)
        self.assertAlmostEqual(s["p99"], 99.01, places=10)  # of |value|
        self.assertEqual(s["max"], 100.0)

    def test_failure_rate_and_reasons(self):
        c = self.cs["counts"]
        self.assertEqual((c["ok"], c["lost"], c["diverged"], c["missing"]), (N_OK, 3, 2, 1))
        self.assertEqual(self.cs["runs"], N_OK + 6)
        self.assertAlmostEqual(self.cs["failure_rate"], 6 / (N_OK + 6), places=12)
        self.assertEqual(sorted(f["run_id"] for f in self.cs["failures"]),
                         [f"run_{k:03d}" for k in range(N_OK, N_OK + 6)])
        missing = [f for f in self.cs["failures"] if f["status"] == "missing"]
        self.assertEqual([f["run_id"] for f in missing], [f"run_{N_OK + 5:03d}"])

    def test_worst_runs_include_diverged_with_replay(self):
        worst = self.cs["worst"]
        self.assertEqual(self.cs["worst_by"], "position_error_m")
        self.assertEqual([w["run_id"] for w in worst],
                         [f"run_{N_OK + 4:03d}", f"run_{N_OK + 3:03d}", "run_099", "run_098", "run_097"])
        for w in worst:
            self.assertIn(f"--replay {w['run_id']} --plan ", w["replay"])
            self.assertIn("runs.json", w["replay"])

    def test_series_statistics_on_common_grid(self):
        ser = self.cs["series"]
        grid = ser["t_rel_s"]
        self.assertEqual(len(grid), 11)  # 0 .. 1.0 s, step = median period 0.1 s
        for i, t in enumerate(grid):
            self.assertAlmostEqual(t, 0.1 * i, places=9)
        pos = ser["position_error_m"]
        # t = 0 and t = 1.0 lie outside the offset runs' span (0.05 .. 0.95 s): only the 50 even runs count.
        self.assertEqual(pos["n"][0], 50)
        self.assertEqual(pos["n"][10], 50)
        self.assertEqual(pos["n"][5], N_OK)
        # Inside: every run, value (k + 1) t -> mean 50.5 t, p99 99.01 t (interpolation exact for linear
        # errors; values rounded to 1e-6 in the summary).
        for i in range(1, 10):
            t = grid[i]
            self.assertAlmostEqual(pos["mean"][i], 50.5 * t, delta=2e-6)
            self.assertAlmostEqual(pos["p99"][i], 99.01 * t, delta=2e-6)
            self.assertAlmostEqual(pos["upper_3sigma"][i], (50.5 + 3 * math.sqrt(100 * 101 / 12)) * t,
                                   delta=2e-6)
        # Even runs only at t = 1.0: values 1, 3, ..., 99.
        evens = [float(k + 1) for k in range(0, N_OK, 2)]
        self.assertAlmostEqual(pos["mean"][10], statistics.mean(evens), delta=2e-6)
        scale = ser["scale_error_percent"]
        self.assertIn("lower_3sigma", scale)
        self.assertIn("p1", scale)

    def test_timing_counts_one_render_per_run(self):
        t = self.summary["timing"]
        self.assertEqual(t["configs_per_render"], 1)
        self.assertEqual(t["vo_runs"], N_OK + 5)
        self.assertEqual(t["campaign"]["wall_s"], 12.0)

    def test_files_written(self):
        for name in ("summary.json", "summary.md", "plots/position_error_m.png",
                     "plots/scale_error_percent.png", "plots/final_error_histogram.png", "plots/outcome.png"):
            self.assertTrue(os.path.isfile(os.path.join(self.tmp, name)), name)
        with open(os.path.join(self.tmp, "summary.md")) as f:
            md = f.read()
        self.assertIn("| a | 106 | 100 | 5.7 % |", md)
        self.assertIn(f"--replay run_{N_OK + 4:03d}", md)

    def test_gather_mode_reports_missing_result(self):
        tmp = tempfile.mkdtemp(prefix="campaign_gather_")
        try:
            plan = make_plan(tmp, 3)
            vc.write_json(os.path.join(tmp, "runs.json"), plan)
            for k in (0, 2):
                write_result(plan, k, "a", "ok", {"position_error_m": 1.0 + k}, {})
            self.assertEqual(vc.main(["--gather", "--output", tmp]), 1)  # run_001 left no result
            summary = util.read_json(os.path.join(tmp, "summary.json"))
            self.assertEqual(summary["configs"]["a"]["counts"]["missing"], 1)
            self.assertEqual(summary["configs"]["a"]["final"]["position_error_m"]["n"], 2)
            write_result(plan, 1, "a", "ok", {"position_error_m": 5.0}, {})
            self.assertEqual(vc.main(["--gather", "--output", tmp]), 0)
            summary = util.read_json(os.path.join(tmp, "summary.json"))
            self.assertEqual(summary["configs"]["a"]["final"]["position_error_m"]["mean"], 3.0)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


class Dispersions(unittest.TestCase):
    DISP = {"terrain_seed": None, "sensor_seed": None, "dems": ["apollo15_gld100", "apollo17_gld100"],
            "placement_ranks": [0, 3], "sun_elevation_deg": [5.0, 45.0], "sun_azimuth_deg": [0.0, 360.0],
            "init_position_sigma_m": 10.0, "init_attitude_sigma_deg": 0.05, "init_scale_sigma_percent": 1.0}

    def test_reproducible_and_independent_of_run_count(self):
        a = [vc.draw_run_params(self.DISP, 42, k) for k in range(5)]
        b = [vc.draw_run_params(self.DISP, 42, k) for k in range(3)]
        self.assertEqual(a[:3], b)
        self.assertNotEqual(a[0], vc.draw_run_params(self.DISP, 43, 0))
        self.assertEqual(len({p["terrain_seed"] for p in a}), 5)
        self.assertEqual(len({p["sensor_seed"] for p in a}), 5)

    def test_fixing_one_dispersion_leaves_the_others(self):
        fixed = dict(self.DISP, sun_elevation_deg=[30.0, 30.0], terrain_seed=7)
        for k in range(10):
            p, q = vc.draw_run_params(self.DISP, 1, k), vc.draw_run_params(fixed, 1, k)
            self.assertEqual(q["sun_elevation_deg"], 30.0)
            self.assertEqual(q["terrain_seed"], 7)
            for key in ("sensor_seed", "dem", "placement_rank", "sun_azimuth_deg", "initial_position_error_m",
                        "initial_attitude_error_deg", "initial_scale_error_percent"):
                self.assertEqual(p[key], q[key], key)

    def test_distributions(self):
        n = 4000
        ps = [vc.draw_run_params(self.DISP, 3, k) for k in range(n)]
        # Uniform placement ranks 0..3 and DEMs: each share within 4 sigma of its expectation.
        for r in range(4):
            share = sum(1 for p in ps if p["placement_rank"] == r) / n
            self.assertLess(abs(share - 0.25), 4 * math.sqrt(0.25 * 0.75 / n), r)
        share = sum(1 for p in ps if p["dem"] == "apollo17_gld100") / n
        self.assertLess(abs(share - 0.5), 4 * math.sqrt(0.25 / n))
        el = [p["sun_elevation_deg"] for p in ps]
        self.assertTrue(all(5.0 <= e <= 45.0 for e in el))
        # Mean of U(5, 45): 25, standard error 40 / sqrt(12 n); 4 sigma.
        self.assertLess(abs(statistics.mean(el) - 25.0), 4 * 40 / math.sqrt(12 * n))
        az = [p["sun_azimuth_deg"] for p in ps]
        self.assertTrue(all(0.0 <= a < 360.0 for a in az))
        # Gaussian initial errors: sample standard deviation within 4 standard errors (sigma / sqrt(2 n)).
        for key, sigma in (("initial_position_error_m", 10.0), ("initial_attitude_error_deg", 0.05)):
            for axis in range(3):
                sd = statistics.pstdev([p[key][axis] for p in ps])
                self.assertLess(abs(sd - sigma), 4 * sigma / math.sqrt(2 * n), (key, axis))
        sd = statistics.pstdev([p["initial_scale_error_percent"] for p in ps])
        self.assertLess(abs(sd - 1.0), 4 * 1.0 / math.sqrt(2 * n))


class Classification(unittest.TestCase):
    VO_OK = {"processed_frames": 100, "poses": 98, "coverage": 0.97,
             "states": {"initialising": 3, "tracking": 95, "lost": 0, "recovered": 2}}

    def test_statuses(self):
        ok_final = {"sim3_ate_percent": 1.0}
        self.assertEqual(vc.classify(1, None, {}, None, {})[0], "render_failed")
        status, reason = vc.classify(0, -11, {}, None, {})
        self.assertEqual((status, reason), ("vo_crashed", "vo_run killed by SIGSEGV"))
        self.assertEqual(vc.classify(0, 1, {}, None, {}), ("vo_crashed", "vo_run exit code 1"))
        self.assertEqual(vc.classify(0, None, {}, None, {}), ("vo_crashed", "vo_run timed out"))
        never = {"processed_frames": 30, "poses": 0, "coverage": 0.0,
                 "states": {"initialising": 30, "tracking": 0, "lost": 0, "recovered": 0}}
        self.assertEqual(vc.classify(0, 0, never, None, {})[0], "never_initialised")
        lost = dict(self.VO_OK, coverage=0.89)
        self.assertEqual(vc.classify(0, 0, lost, 0, ok_final)[0], "lost")
        self.assertEqual(vc.classify(0, 0, dict(self.VO_OK, coverage=0.9), 0, ok_final)[0], "ok")
        self.assertEqual(vc.classify(0, 0, self.VO_OK, 1, {"sim3_ate_percent": None})[0], "eval_failed")
        self.assertEqual(vc.classify(0, 0, self.VO_OK, 0, {"sim3_ate_percent": 5.01})[0], "diverged")
        self.assertEqual(vc.classify(0, 0, self.VO_OK, 0, {"sim3_ate_percent": 5.0}), ("ok", ""))

    def test_vo_run_log_parsing(self):
        tmp = tempfile.mkdtemp(prefix="campaign_log_")
        path = os.path.join(tmp, "vo_run.log")
        with open(path, "w") as f:
            f.write("vo_run: approach_down (planetary_vo, 96x96), map mode, 31 processed frames, "
                    "4 keyframes, 29 poses -> /x/trajectory.txt\nstage median_ms p99_ms\ntotal 1.0 2.0\n"
                    "states: initialising 2, tracking 25, lost 1, recovered 3\n")
        vo = vc.parse_vo_run_log(path)
        shutil.rmtree(tmp)
        self.assertEqual(vo["processed_frames"], 31)
        self.assertEqual(vo["poses"], 29)
        self.assertEqual(vo["states"], {"initialising": 2, "tracking": 25, "lost": 1, "recovered": 3})
        self.assertAlmostEqual(vo["coverage"], 28 / 31)  # held (lost) poses do not count


if __name__ == "__main__":
    unittest.main(verbosity=2)
