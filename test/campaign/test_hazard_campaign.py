"""scripts/hazard_campaign.py --renders-from (docs/terrain/README.md): a one-run campaign at 256 px over the last
5 s of an approach, with --keep-images, then the same draw mapped again from its renders. The second campaign's run
folder must link the first one's dataset (so that site_risk_check.py and shading_calibration.py read it like a
rendered campaign), its navigation must repeat the first one's trajectory exactly (the same images and binaries),
a second --renders-from into the same folder must work with the link already there (and replace a link to
another campaign's render), and renders of another draw (another seed) must be refused. Each terrain_eval of the
campaign states the navigation's error at the end of the run (estimate - truth, the last pose: checked here from the
trajectory and the ground truth) and judges the sites at touchdown too, and site_risk_check.py --navigation-frame
reads it."""
import glob
import json
import os
import shutil
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from campaign_test_util import env_or_exit  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "hazard_campaign.py")
PYTHON = "/usr/bin/python3"
DRAW = ["--runs", "1", "--seed", "3", "--size", "256", "--start-s", "50", "--jobs", "1"]


class HazardCampaignRendersFrom(unittest.TestCase):
    def run_tool(self, *args):
        bin_dir = env_or_exit("PLANETARY_VO_BIN")  # BUILD/devel/lib/planetary_vo
        env = dict(os.environ, PLANETARY_VO_BUILD=os.path.dirname(os.path.dirname(os.path.dirname(bin_dir))))
        return subprocess.run([PYTHON, TOOL] + list(args), capture_output=True, text=True, timeout=240, env=env)

    def test_renders_from_links_the_dataset_and_repeats_the_run(self):
        out = env_or_exit("HAZARD_CAMPAIGN_TEST_OUTPUT")
        shutil.rmtree(out, ignore_errors=True)
        first, second = os.path.join(out, "first"), os.path.join(out, "second")
        done = self.run_tool(*DRAW, "--keep-images", "--out", first)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        rendered = os.path.join(first, "runs", "run_000", "dataset")
        self.assertTrue(os.path.isdir(os.path.join(rendered, "images")), done.stdout)
        self.check_navigation_frame(os.path.join(first, "runs", "run_000"))
        with open(os.path.join(first, "summary.md")) as f:
            self.assertIn("at touchdown: all trials' sites judged", f.read())
        for attempt in range(2):  # the second time the link is already there
            done = self.run_tool(*DRAW, "--renders-from", first, "--out", second)
            self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
            link = os.path.join(second, "runs", "run_000", "dataset")
            self.assertTrue(os.path.islink(link), attempt)
            self.assertEqual(os.path.realpath(link), os.path.realpath(rendered))
            self.assertFalse(os.path.exists(os.path.join(second, "runs", "run_000", "render.log")))
            with open(os.path.join(first, "runs", "run_000", "trajectory.txt")) as a, \
                    open(os.path.join(second, "runs", "run_000", "trajectory.txt")) as b:
                self.assertEqual(a.read(), b.read())
        # A link to another campaign's render (an earlier --renders-from into this folder) is replaced.
        os.remove(link)
        os.symlink(out, link)
        done = self.run_tool(*DRAW, "--renders-from", first, "--out", second)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        self.assertEqual(os.path.realpath(link), os.path.realpath(rendered))
        # The analysis scripts read the re-mapped folder's true terrain through the link.
        risk = subprocess.run([PYTHON, os.path.join(ROOT, "scripts", "site_risk_check.py"), second, "--margins", "2"],
                              capture_output=True, text=True, timeout=120)
        self.assertEqual(risk.returncode, 0, risk.stdout + risk.stderr)
        self.assertIn("all 1 maps:", risk.stdout)
        risk = subprocess.run([PYTHON, os.path.join(ROOT, "scripts", "site_risk_check.py"), second, "--margins", "2",
                               "--navigation-frame"], capture_output=True, text=True, timeout=120)
        self.assertEqual(risk.returncode, 0, risk.stdout + risk.stderr)
        self.assertIn("all 1 maps:", risk.stdout)
        # Renders of another draw are refused.
        other = self.run_tool("--runs", "1", "--seed", "4", "--size", "256", "--start-s", "50", "--jobs", "1",
                              "--renders-from", first, "--out", os.path.join(out, "other"))
        self.assertNotEqual(other.returncode, 0, other.stdout)
        self.assertIn("is another draw or kept no images", other.stdout + other.stderr)

    def check_navigation_frame(self, run):
        """The navigation error in every terrain_eval JSON of the run is the last estimated pose's position minus
        the ground truth interpolated at its stamp, the same in all of them and in result.json."""
        def poses(path):
            with open(path) as f:
                return [[float(v) for v in line.split()[:4]] for line in f if line.strip() and line[0] != "#"]
        last = poses(os.path.join(run, "trajectory.txt"))[-1]
        truth = poses(os.path.join(run, "dataset", "groundtruth.txt"))
        after = next(i for i, p in enumerate(truth) if p[0] >= last[0])
        a, b = truth[max(0, after - 1)], truth[after]
        w = 0.0 if b[0] == a[0] else (last[0] - a[0]) / (b[0] - a[0])
        expected = [last[k] - (a[k] + w * (b[k] - a[k])) for k in (1, 2, 3)]
        jsons = glob.glob(os.path.join(run, "t*.json"))
        self.assertEqual(len(jsons), 9)
        for path in jsons:
            with open(path) as f:
                result = json.load(f)
            for got, want in zip(result["navigation_error_m"], expected):
                self.assertAlmostEqual(got, want, delta=1e-6)
            self.assertIn("slope_rmse_deg", result["navigation_frame"]["full_resolution"])
            if result["landing_site"] is not None:
                self.assertIn(result["landing_site"]["safe_at_touchdown"], (True, False))
        with open(os.path.join(run, "result.json")) as f:
            self.assertEqual(json.load(f)["scores"]["navigation_error_m"], result["navigation_error_m"])


if __name__ == "__main__":
    unittest.main(verbosity=2)
