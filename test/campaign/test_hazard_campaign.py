"""scripts/hazard_campaign.py --renders-from (docs/terrain/README.md): a one-run campaign at 256 px over the last
5 s of an approach, with --keep-images, then the same draw mapped again from its renders. The second campaign's run
folder must link the first one's dataset (so that site_risk_check.py and shading_calibration.py read it like a
rendered campaign), its navigation must repeat the first one's trajectory exactly (the same images and binaries),
a second --renders-from into the same folder must work with the link already there (and replace a link to
another campaign's render), and renders of another draw (another seed) must be refused."""
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
        # Renders of another draw are refused.
        other = self.run_tool("--runs", "1", "--seed", "4", "--size", "256", "--start-s", "50", "--jobs", "1",
                              "--renders-from", first, "--out", os.path.join(out, "other"))
        self.assertNotEqual(other.returncode, 0, other.stdout)
        self.assertIn("is another draw or kept no images", other.stdout + other.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
