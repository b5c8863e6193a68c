#!/usr/bin/python3
"""End to end: a tiny campaign on the local process pool with the real lunar_render, vo_run and vo_eval, then
the replay of one run alone. Environment (set by ctest, cmake/campaign_tests.cmake): PLANETARY_VO_BIN (tools),
CAMPAIGN_TEST_OUTPUT (work folder)."""
import glob
import os
import re
import shutil
import sys
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import campaign_test_util as util  # noqa: E402

vc = util.load_tool()


class LocalCampaign(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = util.output_dir("campaign_local")
        shutil.rmtree(cls.work, ignore_errors=True)  # fresh renders: no cache hit from an earlier test run
        cls.out = os.path.join(cls.work, "campaign")
        cls.docs = os.path.join(cls.work, "docs")
        no_ba = util.write_no_ba_config(cls.work)
        # The tools behind shims that log every call: renders counted independently of the tool's reports.
        cls.calls = os.path.join(cls.work, "calls")
        shims = util.counting_shims(os.path.join(cls.work, "bin"), util.bin_dir(), cls.calls)
        args = util.CAMPAIGN_ARGS + ["--configs", f"default,{no_ba}", "--bin", shims, "--jobs", "2",
                                     "--output", cls.out, "--name", "local_test"]
        cls.proc = util.run_tool(args + ["--write-docs", cls.docs])
        print(cls.proc.stdout)
        print(cls.proc.stderr, file=sys.stderr)
        cls.plan = util.read_json(os.path.join(cls.out, "runs.json"))
        cls.summary = util.read_json(os.path.join(cls.out, "summary.json"))
        cls.results = cls.read_results()
        cls.renders = [util.read_json(os.path.join(r["dir"], "render.json")) for r in cls.plan["runs"]]
        cls.first_calls = util.read_calls(cls.calls)
        # The same command again: lunar_render's cache skips every render, the VO runs again.
        cls.again = util.run_tool(args)
        cls.again_summary = util.read_json(os.path.join(cls.out, "summary.json"))
        cls.again_results = cls.read_results()
        cls.all_calls = util.read_calls(cls.calls)

    @classmethod
    def read_results(cls):
        return {(r["id"], c["name"]): util.read_json(os.path.join(r["dir"], c["name"], "result.json"))
                for r in cls.plan["runs"] for c in cls.plan["configs"]}

    def test_campaign_succeeded(self):
        self.assertEqual(self.proc.returncode, 0, self.proc.stderr)

    def test_plan_lists_dispersed_runs_and_their_commands(self):
        runs = self.plan["runs"]
        self.assertEqual([r["id"] for r in runs], [f"run_{k:03d}" for k in range(util.RUNS)])
        self.assertEqual([c["name"] for c in self.plan["configs"]], ["default", "no_ba"])
        self.assertEqual(len({r["params"]["terrain_seed"] for r in runs}), util.RUNS)
        for r in runs:
            p = r["params"]
            # The dispersions are the seeded draw of run k (reproducible from the campaign seed 7).
            self.assertEqual(p, vc.draw_run_params(self.plan["dispersions"], 7, r["index"]))
            self.assertTrue(5.0 <= p["sun_elevation_deg"] <= 20.0)
            render = r["commands"]["render"]
            self.assertEqual(render[render.index("--seed") + 1], str(p["terrain_seed"]))
            self.assertEqual(float(render[render.index("--sun-elevation") + 1]), p["sun_elevation_deg"])
            self.assertEqual(float(render[render.index("--sun-azimuth") + 1]), p["sun_azimuth_deg"])
            self.assertEqual(render[render.index("--dem") + 1], p["dem"])
            if "--sensor-seed" in render:
                self.assertEqual(render[render.index("--sensor-seed") + 1], str(p["sensor_seed"]))
            for name, cmds in r["commands"]["configs"].items():
                self.assertIn("--align", cmds["eval_sim3"])
                if self.plan["eval"]["first_pose"]:
                    first = cmds["eval_first"]
                    err = [float(v) for v in first[first.index("--initial-error-m") + 1].split(",")]
                    np.testing.assert_allclose(err, p["initial_position_error_m"], atol=1e-12)

    def test_one_render_per_run_shared_by_the_configurations(self):
        renders = [c for c in self.first_calls["lunar_render"] if "--help" not in c]
        self.assertEqual(len(renders), util.RUNS)
        self.assertEqual(sorted(c[c.index("--output") + 1] for c in renders),
                         sorted(os.path.join(r["dir"], "dataset") for r in self.plan["runs"]))
        self.assertEqual(len([c for c in self.first_calls["vo_run"] if "--help" not in c]), 2 * util.RUNS)
        for r, render in zip(self.plan["runs"], self.renders):
            self.assertEqual(render["rc"], 0)
            self.assertFalse(render["cached"])
            for c in self.plan["configs"]:
                t = self.results[(r["id"], c["name"])]["timing"]
                self.assertEqual(t["render_cpu_s"], render["cpu_s"])  # the same render, not one each
                self.assertGreater(t["vo_wall_s"], 0.0)
        t = self.summary["timing"]
        self.assertEqual((t["renders"], t["vo_runs"], t["configs_per_render"]), (util.RUNS, 2 * util.RUNS, 2))
        self.assertGreater(t["render_cpu_total_s"], 0.0)
        self.assertAlmostEqual(t["render_cpu_saved_s"], t["render_cpu_total_s"], delta=0.011)
        self.assertGreater(t["campaign"]["wall_s"], 0.0)
        self.assertIn("load_average_start", t["campaign"])

    def test_second_execution_uses_the_render_cache(self):
        self.assertEqual(self.again.returncode, 0, self.again.stderr)
        t = self.again_summary["timing"]
        self.assertEqual((t["renders"], t["renders_cached"]), (util.RUNS, util.RUNS))
        calls = [c for c in self.all_calls["lunar_render"] if "--help" not in c]
        self.assertEqual(len(calls), 2 * util.RUNS)  # called again, and it skipped the complete renders
        for key, result in self.again_results.items():
            self.assertTrue(result["timing"]["render_cached"])
            self.assertEqual(vc.deterministic_part(result), vc.deterministic_part(self.results[key]), key)

    def test_results_have_status_and_metrics(self):
        n_ok = 0
        for (run_id, config), res in self.results.items():
            self.assertEqual((res["run_id"], res["config"]), (run_id, config))
            self.assertIn(res["status"], ["ok"] + vc.FAILURE_STATUSES)
            self.assertNotEqual(res["status"], "missing")
            if res["status"] == "ok":
                n_ok += 1
                self.assertGreaterEqual(res["vo"]["coverage"], vc.MIN_COVERAGE)
                self.assertLessEqual(res["final"]["sim3_ate_percent"], vc.DIVERGED_ATE_PERCENT)
                if self.plan["eval"]["first_pose"]:
                    self.assertIsNotNone(res["final"]["position_error_m"])
                    self.assertIn("position_error_m", res["series"])
            else:
                self.assertTrue(res["reason"])
        self.assertGreater(n_ok, 0, "no run reached the evaluation: the statistics below would check nothing")

    def test_summary_statistics_match_the_result_files(self):
        for c in self.plan["configs"]:
            cs = self.summary["configs"][c["name"]]
            rs = [self.results[(r["id"], c["name"])] for r in self.plan["runs"]]
            ok = [r for r in rs if r["status"] == "ok"]
            self.assertEqual(cs["runs"], util.RUNS)
            self.assertEqual(cs["ok"], len(ok))
            self.assertAlmostEqual(cs["failure_rate"], 1 - len(ok) / util.RUNS, places=12)
            self.assertEqual(sum(cs["counts"].values()), util.RUNS)
            for key, _, _, signed in vc.METRICS:
                values = [r["final"][key] for r in ok if r["final"][key] is not None]
                s = cs["final"][key]
                self.assertEqual(s["n"], len(values), key)
                if values:
                    self.assertAlmostEqual(s["mean"], float(np.mean(values)), places=9, msg=key)
                    mags = np.abs(values) if signed else np.array(values)
                    self.assertAlmostEqual(s["max"], float(np.max(mags)), places=9, msg=key)
                    self.assertAlmostEqual(s["p99"], float(np.percentile(mags, 99)), places=9, msg=key)
                    if len(values) > 1:
                        self.assertAlmostEqual(s["std"], float(np.std(values, ddof=1)), places=9, msg=key)
            ranked = sorted([r for r in rs if r["final"].get(cs["worst_by"]) is not None],
                            key=lambda r: -r["final"][cs["worst_by"]])
            self.assertEqual([w["run_id"] for w in cs["worst"]],
                             [r["run_id"] for r in ranked[:vc.WORST_RUNS]])
            if self.plan["eval"]["first_pose"] and ok:
                self.assertIn("position_error_m", cs["series"])
                self.assertEqual(len(cs["series"]["position_error_m"]["mean"]), len(cs["series"]["t_rel_s"]))

    def test_progress_one_line_per_run_with_eta(self):
        lines = [ln for ln in self.proc.stdout.splitlines() if re.match(r"^\[\s*\d+/\d+\] run_\d{3} ", ln)]
        self.assertEqual(len(lines), util.RUNS)
        self.assertEqual(sorted(re.search(r"run_\d{3}", ln).group(0) for ln in lines),
                         [r["id"] for r in self.plan["runs"]])
        for ln in lines:
            self.assertRegex(ln, r"elapsed \d+:\d\d  ETA \d+:\d\d$")

    def test_report_files_and_docs_copy(self):
        expected = ["summary.md", "summary.json", "plots/final_error_histogram.png", "plots/outcome.png"]
        if self.plan["eval"]["first_pose"]:
            expected += [f"plots/{m[0]}.png" for m in vc.SERIES_METRICS
                         if any(m[0] in cs["series"] for cs in self.summary["configs"].values())]
            self.assertIn("plots/position_error_m.png", expected)
        for name in expected:
            for folder in (self.out, self.docs):
                path = os.path.join(folder, name)
                self.assertTrue(os.path.isfile(path) and os.path.getsize(path) > 0, path)
        def plots(folder):
            return sorted(os.path.basename(p) for p in glob.glob(os.path.join(folder, "plots", "*")))

        self.assertEqual(plots(self.docs), plots(self.out))
        with open(os.path.join(self.out, "summary.md")) as f:
            md = f.read()
        for c in self.plan["configs"]:
            self.assertIn(f"## {c['name']}: errors at the end", md)
        self.assertIn("--replay run_", md)

    def test_gather_reproduces_the_summary(self):
        # The summary in the folder is the second execution's (same results, other timing).
        before = {k: v for k, v in self.again_summary.items() if k != "created_utc"}
        proc = util.run_tool(["--gather", "--output", self.out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        after = util.read_json(os.path.join(self.out, "summary.json"))
        after.pop("created_utc")
        self.assertEqual(after, before)

    def test_replay_reproduces_a_run_exactly(self):
        # The worst evaluated run of the default configuration (the one a reviewer would replay), else run 0.
        worst = self.summary["configs"]["default"]["worst"]
        self.assertTrue(worst)
        run_id = worst[0]["run_id"]
        replay_dir = os.path.join(self.work, "replay")
        proc = util.run_tool(["--replay", run_id, "--plan", os.path.join(self.out, "runs.json"), "--output",
                              replay_dir])
        print(proc.stdout)
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertEqual(proc.stdout.count("identical to the campaign's result"), 2)
        for c in self.plan["configs"]:
            replayed = util.read_json(os.path.join(replay_dir, c["name"], "result.json"))
            original = self.results[(run_id, c["name"])]
            self.assertEqual(vc.deterministic_part(replayed), vc.deterministic_part(original))
            # Bit-identical trajectory, not only equal metrics.
            with open(os.path.join(replay_dir, c["name"], "trajectory.txt")) as f:
                a = f.read()
            run_dir = [r["dir"] for r in self.plan["runs"] if r["id"] == run_id][0]
            with open(os.path.join(run_dir, c["name"], "trajectory.txt")) as f:
                self.assertEqual(a, f.read())


if __name__ == "__main__":
    unittest.main(verbosity=2)
