"""End to end: scripts/vo_sensitivity.py (docs/visual_core.md, sensitivity study) with the real vo_run and
vo_eval on the VO rostests' short Lunar descent (256 px, 6 s): two parameters of four values each, the base
values shared, the tables, the cliff column, the plots, a second invocation reusing every run, and bad input
refused with a message."""
import json
import os
import shutil
import subprocess
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "vo_sensitivity.py")
PYTHON = "/usr/bin/python3"
PARAMS = "lk_levels,kf_track_ratio"  # 4 + 4 settings; each has the base value: 7 distinct configurations


def env_or_exit(name):
    value = os.environ.get(name)
    if not value:
        sys.exit(f"{name} must be set (ctest sets it)")
    return value


class SensitivityTool(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.bin = env_or_exit("PLANETARY_VO_BIN")
        cls.dataset = env_or_exit("PLANETARY_VO_TEST_DATASET")
        cls.out = os.path.join(env_or_exit("SENSITIVITY_TEST_OUTPUT"))
        shutil.rmtree(cls.out, ignore_errors=True)
        # --build takes the folder above devel/lib/planetary_vo.
        cls.build = os.path.dirname(os.path.dirname(os.path.dirname(cls.bin.rstrip("/"))))
        cls.first = cls.run_tool(["--datasets", cls.dataset, "--params", PARAMS, "--jobs", "2",
                                  "--output", os.path.join(cls.out, "run"),
                                  "--write-docs", os.path.join(cls.out, "docs")])

    @classmethod
    def run_tool(cls, args):
        return subprocess.run([PYTHON, TOOL, "--build", cls.build] + args, capture_output=True, text=True,
                              timeout=240)

    def test_runs_every_setting_once(self):
        self.assertEqual(self.first.returncode, 0, self.first.stdout + self.first.stderr)
        with open(os.path.join(self.out, "run", "results.json")) as f:
            results = json.load(f)["results"]
        self.assertEqual(len(results), 8)
        run_logs = [d for d in os.listdir(os.path.join(self.out, "run", "runs"))]
        self.assertEqual(len(run_logs), 7, "the base configuration is run once for both parameters")
        shared = [r for r in results if "shares_runs_of" in r]
        self.assertEqual(len(shared), 1)
        self.assertEqual(shared[0]["setting"], "kf_track_ratio_0.8")
        base = [r for r in results if r["setting"] == "lk_levels_3"][0]
        self.assertEqual(shared[0]["ate_percent"], base["ate_percent"])
        for r in results:
            self.assertTrue(r["ok"], r)  # this clip is tracked with each of these settings
            self.assertGreater(r["ate_percent"], 0.0)
            self.assertLess(r["ate_percent"], 5.0)

    def test_summary_tables_and_plots(self):
        with open(os.path.join(self.out, "docs", "summary.md")) as f:
            summary = f.read()
        name = os.path.basename(self.dataset.rstrip("/"))
        self.assertIn("## lk_levels", summary)
        self.assertIn("## kf_track_ratio", summary)
        self.assertIn("| 1 | 2 | **3** | 4 |", summary)  # the base value in bold
        rows = [line for line in summary.splitlines() if line.startswith(f"| {name} |")]
        self.assertEqual(len(rows), 2)  # one row per parameter table (the overview has the name as a column)
        for p in PARAMS.split(","):
            self.assertGreater(os.path.getsize(os.path.join(self.out, "docs", "plots", p + ".png")), 10000)
        # The worst ratio in the table is the largest ATE over the smallest one of that parameter.
        with open(os.path.join(self.out, "run", "results.json")) as f:
            analysis = json.load(f)["analysis"]
        d = analysis["lk_levels"]["per_dataset"][name]
        self.assertAlmostEqual(d["worst_ratio"], max(d["ate"]) / min(d["ate"]), places=9)
        self.assertEqual(d["cliff"], d["worst_ratio"] > 2.0)

    def test_second_invocation_reuses_every_run(self):
        again = self.run_tool(["--datasets", self.dataset, "--params", PARAMS, "--jobs", "2",
                               "--output", os.path.join(self.out, "run")])
        self.assertEqual(again.returncode, 0, again.stderr)
        progress = [line for line in again.stdout.splitlines() if line.startswith("[")]
        self.assertEqual(len(progress), 7, again.stdout)  # one line per distinct run
        self.assertTrue(all(" reused " in line for line in progress), again.stdout)

    def test_bad_input_is_refused_with_a_message(self):
        unknown = self.run_tool(["--datasets", self.dataset, "--params", "lk_levls",
                                 "--output", os.path.join(self.out, "bad")])
        self.assertNotEqual(unknown.returncode, 0)
        self.assertIn("unknown parameter lk_levls", unknown.stderr)
        missing = self.run_tool(["--datasets", os.path.join(self.out, "no_such_dataset"),
                                 "--output", os.path.join(self.out, "bad")])
        self.assertNotEqual(missing.returncode, 0)
        self.assertIn("is not a dataset folder", missing.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
