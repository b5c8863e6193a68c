#!/usr/bin/python3
"""The campaign through a real single-node Slurm: scripts/slurm_local.sh starts munged, slurmctld and slurmd
in a folder of their own, the campaign runs as one array job (one task per run), and its results must equal
those of the same campaign on the local process pool. The cluster is stopped even when a check fails. Needs
root and the Debian packages munge, slurmctld, slurmd, slurm-client. Environment as test_campaign_local.py."""
import hashlib
import os
import re
import shutil
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import campaign_test_util as util  # noqa: E402

vc = util.load_tool()


def cluster_dir(work):
    """A fixed folder per build (a cluster left over by a killed test run is stopped by the next start) under
    /tmp: munged's socket path must stay below the 108 characters of a Unix socket name."""
    return os.path.join("/tmp", "pvo_slurm_" + hashlib.sha1(os.path.abspath(work).encode()).hexdigest()[:10])


def slurm_local(action, folder, timeout=120):
    return subprocess.run(["bash", util.SLURM_LOCAL, action, folder], capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


class SlurmCampaign(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = util.output_dir("campaign_slurm")
        shutil.rmtree(cls.work, ignore_errors=True)
        os.makedirs(cls.work)
        cls.cluster = cluster_dir(cls.work)
        no_ba = util.write_no_ba_config(cls.work)
        common = util.CAMPAIGN_ARGS + ["--configs", f"default,{no_ba}", "--bin", util.bin_dir(), "--name",
                                       "slurm_test"]
        cls.local_out = os.path.join(cls.work, "local")
        cls.slurm_out = os.path.join(cls.work, "slurm")
        # Time limits: 100 s + 120 s + start and stop stay below ctest's 300 s, so that the cluster is always
        # stopped by this file (the campaigns take ~10-25 s each on the loaded 2-core machine).
        cls.local = util.run_tool(common + ["--jobs", "2", "--output", cls.local_out], timeout=100)
        start = slurm_local("start", cls.cluster)
        cls.started = start
        try:
            if start.returncode != 0:
                raise RuntimeError(f"slurm_local.sh start failed:\n{start.stdout}\n{start.stderr}")
            m = re.search(r"^export SLURM_CONF=(\S+)$", start.stdout, re.M)
            if not m:
                raise RuntimeError(f"slurm_local.sh start printed no SLURM_CONF:\n{start.stdout}")
            env = dict(os.environ, SLURM_CONF=m.group(1))
            cls.slurm_conf = m.group(1)
            cls.slurm = util.run_tool(common + ["--scheduler", "slurm", "--poll-interval", "0.5",
                                                "--slurm-timeout", "90", "--output", cls.slurm_out],
                                      timeout=120, env=env)
            print(cls.slurm.stdout)
            print(cls.slurm.stderr, file=sys.stderr)
            with open(os.path.join(cls.cluster, "logs", "jobcomp.txt")) as f:
                cls.jobcomp = f.read()
            status = subprocess.run(["sinfo", "-h", "-N", "-o", "%N %t"], capture_output=True, text=True,
                                    timeout=30, env=env)
            cls.sinfo = status.stdout
        finally:
            stop = slurm_local("stop", cls.cluster)
            cls.stopped = stop
            cls.status_after_stop = slurm_local("status", cls.cluster)

    def test_cluster_started_and_stopped(self):
        self.assertEqual(self.started.returncode, 0, self.started.stderr)
        self.assertIn("localhost", self.sinfo)
        self.assertEqual(self.stopped.returncode, 0, self.stopped.stderr)
        # status exits non-zero and names no running daemon once the cluster is stopped.
        self.assertNotEqual(self.status_after_stop.returncode, 0)
        self.assertNotIn("running (pid", self.status_after_stop.stdout)

    def test_campaigns_succeeded(self):
        self.assertEqual(self.local.returncode, 0, self.local.stderr)
        self.assertEqual(self.slurm.returncode, 0, self.slurm.stderr)
        self.assertIn(f"({util.RUNS} tasks, {self.slurm_conf})", self.slurm.stdout)

    def test_sbatch_script_is_one_array_task_per_run(self):
        with open(os.path.join(self.slurm_out, "slurm", "campaign.sbatch")) as f:
            script = f.read()
        self.assertIn(f"#SBATCH --array=0-{util.RUNS - 1}\n", script)
        self.assertIn('--run-one "$SLURM_ARRAY_TASK_ID"', script)

    def test_every_task_ran_as_its_own_slurm_job(self):
        plan = util.read_json(os.path.join(self.slurm_out, "runs.json"))
        with open(os.path.join(self.slurm_out, "slurm", "job_id.txt")) as f:
            array_job = f.read().strip()
        job_ids = set()
        for run in plan["runs"]:
            k = run["index"]
            with open(os.path.join(self.slurm_out, "slurm", "logs", f"task_{k}.out")) as f:
                log = f.read()
            m = re.search(r"SLURM_JOB_ID=(\d+) SLURM_ARRAY_JOB_ID=(\d+) +SLURM_ARRAY_TASK_ID=(\d+)", log)
            self.assertIsNotNone(m, log)
            self.assertEqual((m.group(2), m.group(3)), (array_job, str(k)))
            # The controller's own record of the task (jobcomp/filetxt): completed, this array, this index.
            rec = re.search(rf"(?<!Array)JobId={m.group(1)} .*JobState=(\S+) .*"
                            rf"ArrayJobId={array_job} ArrayTaskId={k} ", self.jobcomp)
            self.assertIsNotNone(rec, f"no jobcomp record of task {k}:\n{self.jobcomp}")
            self.assertEqual(rec.group(1), "COMPLETED")
            for c in plan["configs"]:
                ex = util.read_json(os.path.join(run["dir"], c["name"], "result.json"))["executor"]
                self.assertEqual((ex["slurm_job_id"], ex["slurm_array_job_id"], ex["slurm_array_task_id"]),
                                 (m.group(1), array_job, str(k)))
            job_ids.add(m.group(1))
        self.assertEqual(len(job_ids), util.RUNS)

    def test_results_identical_to_the_local_run(self):
        local_plan = util.read_json(os.path.join(self.local_out, "runs.json"))
        slurm_plan = util.read_json(os.path.join(self.slurm_out, "runs.json"))
        self.assertEqual([r["params"] for r in local_plan["runs"]], [r["params"] for r in slurm_plan["runs"]])
        for a, b in zip(local_plan["runs"], slurm_plan["runs"]):
            for c in local_plan["configs"]:
                ra = util.read_json(os.path.join(a["dir"], c["name"], "result.json"))
                rb = util.read_json(os.path.join(b["dir"], c["name"], "result.json"))
                self.assertEqual(vc.deterministic_part(ra), vc.deterministic_part(rb), (a["id"], c["name"]))
                self.assertNotIn("slurm_job_id", ra["executor"])
        sa = util.read_json(os.path.join(self.local_out, "summary.json"))
        sb = util.read_json(os.path.join(self.slurm_out, "summary.json"))
        for name in sa["configs"]:
            for key in ("counts", "failure_rate", "final", "series", "worst_by"):
                self.assertEqual(sa["configs"][name][key], sb["configs"][name][key], (name, key))
            self.assertEqual([w["run_id"] for w in sa["configs"][name]["worst"]],
                             [w["run_id"] for w in sb["configs"][name]["worst"]])
        self.assertEqual(sb["timing"]["campaign"]["scheduler"], "slurm")
        self.assertEqual((sb["timing"]["renders"], sb["timing"]["vo_runs"]), (util.RUNS, 2 * util.RUNS))

    def test_progress_from_the_result_files(self):
        lines = [ln for ln in self.slurm.stdout.splitlines() if re.match(r"^\[\s*\d+/\d+\] run_\d{3} ", ln)]
        self.assertEqual(len(lines), util.RUNS)
        for ln in lines:
            self.assertRegex(ln, r"\[job \d+\]  elapsed \d+:\d\d  ETA \d+:\d\d$")


if __name__ == "__main__":
    unittest.main(verbosity=2)
