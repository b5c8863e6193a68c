"""scripts/velocity_nees.py on files with a known answer: errors of (1, 0, 0) and (0, 2, 0) m/s with covariances
I and diag(1, 4, 1) give a NEES of 1 each (mean 1.00, all below 7.81); an error of 3 m/s with P = I gives 9
(above the bound); a line without its covariance is refused."""
import os
import subprocess
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "velocity_nees.py")


def run(gt, est):
    with tempfile.TemporaryDirectory() as d:
        g, e = os.path.join(d, "gt.txt"), os.path.join(d, "v.txt")
        open(g, "w").write(gt)
        open(e, "w").write(est)
        return subprocess.run(["/usr/bin/python3", SCRIPT, "--gt-state", g, "--est-velocity", e],
                               capture_output=True, text=True)


GT = ("# t p q v bg ba\n"
      "1.0 0 0 0 0 0 0 1 10 0 0 0 0 0 0 0 0\n"
      "1.1 0 0 0 0 0 0 1 10 0 0 0 0 0 0 0 0\n"
      "1.2 0 0 0 0 0 0 1 10 0 0 0 0 0 0 0 0\n")


class VelocityNees(unittest.TestCase):
    def test_consistent(self):
        r = run(GT, "# t v P\n1.0 11 0 0 1 0 0 0 1 0 0 0 1\n1.1 10 2 0 1 0 0 0 4 0 0 0 1\n")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("over 2 estimates: mean 1.00", r.stdout)
        self.assertIn("below 7.81 (95 % of chi-square 3): 100 %", r.stdout)

    def test_overconfident(self):
        r = run(GT, "1.2 13 0 0 1 0 0 0 1 0 0 0 1\n")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("mean 9.00", r.stdout)
        self.assertIn(": 0 %", r.stdout)

    def test_without_covariance_is_refused(self):
        r = run(GT, "1.0 10 0 0\n")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("expected t, 3 velocity and 9 covariance values, got 4", r.stderr)


if __name__ == "__main__":
    unittest.main()
