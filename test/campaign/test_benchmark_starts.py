"""scripts/vo_benchmark.py: --starts (docs/visual_core.md, step 8): a row run again from later input images with the
real vo_run and vo_eval on the VO rostests' short Lunar descent (256 px, 6 s), each start scored like the row's
own run, and the median over the starts as the benchmark prints it (a lost start counted as the worst); and
--write-docs, which keeps the hand-written sections of docs/results.md."""
import json
import os
import shutil
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from campaign_test_util import env_or_exit, first_pose_time  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import vo_benchmark  # noqa: E402


class BenchmarkStarts(unittest.TestCase):
    def test_each_start_runs_from_its_own_image_and_is_scored(self):
        bin_dir = env_or_exit("PLANETARY_VO_BIN")
        dataset = env_or_exit("PLANETARY_VO_TEST_DATASET")
        out = env_or_exit("BENCHMARK_STARTS_TEST_OUTPUT")
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        config = os.path.join(ROOT, "config", "default.yaml")
        stamp = os.path.join(dataset, "times.txt")
        scores = vo_benchmark.score_starts(bin_dir, dataset, dataset, config, out, "approach_down", 3, False, stamp)
        self.assertEqual(len(scores["ate_percent"]), 2)  # starts 1 and 2; start 0 is the row's own run
        for ate, kf, coverage in zip(scores["ate_percent"], scores["keyframes_ate_percent"], scores["coverage"]):
            self.assertGreaterEqual(coverage, vo_benchmark.MIN_COVERAGE)
            self.assertGreater(ate, 0.0)
            self.assertLess(ate, 5.0)  # this descent is tracked from each of these images
            self.assertGreater(kf, 0.0)
            self.assertLess(kf, 5.0)
        # Start n begins n images later: its first pose is later than start n-1's.
        t1 = first_pose_time(os.path.join(out, "start1", "trajectory.txt"))
        t2 = first_pose_time(os.path.join(out, "start2", "trajectory.txt"))
        self.assertLess(t1, t2)
        with open(os.path.join(out, "start2", "eval_sim3.json")) as f:
            self.assertAlmostEqual(json.load(f)["ate_rmse_percent_of_path"], scores["ate_percent"][1], places=12)
        # A second call reuses the current runs (same dataset, configuration and binary) and scores the same.
        again = vo_benchmark.score_starts(bin_dir, dataset, dataset, config, out, "approach_down", 3, False, stamp)
        self.assertEqual(again, scores)

    def test_the_median_counts_a_lost_start_as_the_worst(self):
        row = {"coverage": 1.0, "ate_percent": 0.03,
               "starts": {"ate_percent": [0.01, 0.05, None, 0.02], "keyframes_ate_percent": [0.01, 0.02, 0.03, 0.04]}}
        # 0.01, 0.02, 0.03, 0.05 and one lost (inf): the median is 0.03.
        self.assertEqual(vo_benchmark.fmt_starts(row, "ate_percent"), "0.0300 (0.0100-0.0500, 1 lost)")
        row["keyframes_ate_percent"] = 0.05
        self.assertEqual(vo_benchmark.fmt_starts(row, "keyframes_ate_percent"), "0.0300 (0.0100-0.0500)")
        # The row's own run lost (under 90 % posed): it counts as lost whatever its ATE.
        lost_first = {"coverage": 0.5, "ate_percent": 0.001, "starts": {"ate_percent": [None, None]}}
        self.assertEqual(vo_benchmark.fmt_starts(lost_first, "ate_percent"), "lost")
        self.assertEqual(vo_benchmark.fmt_starts({"ate_percent": 0.02}, "ate_percent"), "-")
        self.assertEqual(vo_benchmark.median([3.0, 1.0, 2.0, 4.0]), 2.5)

    def test_write_docs_keeps_every_hand_written_section(self):
        # --write-docs regenerates the table and the plots of docs/results.md; the sections written by hand
        # under the table (earlier re-runs, "What the table says") stay, whichever groups were run this time.
        import tempfile
        import types
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "docs"))
            results_md = os.path.join(root, "docs", "results.md")
            with open(results_md, "w") as f:
                f.write("# VO benchmark results\n\nold header\n\n| old table |\n\n"
                        "## Re-run with the defaults of session 21\n\nkept 1\n\n"
                        "## What the table says\n\nkept 2\n\n![plot](results/x.png)\n")
            saved = vo_benchmark.ROOT
            vo_benchmark.ROOT = root
            try:
                vo_benchmark.write_docs("| new table |", [], types.SimpleNamespace(duration=None, output=root))
            finally:
                vo_benchmark.ROOT = saved
            with open(results_md) as f:
                text = f.read()
        self.assertIn("| new table |", text)
        self.assertNotIn("| old table |", text)
        self.assertIn("## Re-run with the defaults of session 21\n\nkept 1", text)
        self.assertIn("## What the table says\n\nkept 2", text)
        self.assertNotIn("results/x.png", text)  # the plots are written again from the rows run
        self.assertLess(text.index("| new table |"), text.index("## Re-run"))


if __name__ == "__main__":
    unittest.main(verbosity=2)
