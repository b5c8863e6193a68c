"""Helpers of the campaign tests test/campaign/test_campaign_*.py."""
import importlib.util
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "vo_campaign.py")
SLURM_LOCAL = os.path.join(ROOT, "scripts", "slurm_local.sh")
PYTHON = "/usr/bin/python3"

# The end-to-end campaign of the local and Slurm tests: 3 runs, 2 configurations (default, and default without
# bundle adjustment, given as a YAML path), approach_down at 96 px for 3 s (31 frames: ~0.5 s of CPU to render
# a run). Sun elevation 5-20 deg: at 96 px a high Sun leaves too little texture for the initialisation in 3 s
# (measured: runs at 42 and 45 deg never initialised), and the test needs runs that reach the evaluation. The
# scale of the first-pose evaluation is taken over the first 1 s (the default 2 s window is most of the clip).
RUNS = 3
CAMPAIGN_ARGS = ["--sequence", "approach_down", "--runs", str(RUNS), "--size", "96", "--duration", "3",
                 "--seed", "7", "--sun-elevation", "5,20", "--first-scale-window", "1",
                 "--tool-timeout", "120"]
NO_BA_YAML = "bundle_adjustment:\n  enabled: false\n"


def load_tool():
    """scripts/vo_campaign.py as a module (its statistics and classification functions)."""
    spec = importlib.util.spec_from_file_location("vo_campaign", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def env_or_exit(name):
    """An environment variable ctest sets, or exit with a message naming it."""
    value = os.environ.get(name)
    if not value:
        sys.exit(f"{name} must be set (ctest sets it)")
    return value


def first_pose_time(trajectory_path):
    """Time stamp of the first pose of a TUM-format trajectory (comment lines skipped)."""
    with open(trajectory_path) as f:
        return float(next(line for line in f if line.strip() and not line.startswith("#")).split()[0])


def bin_dir():
    d = os.environ.get("PLANETARY_VO_BIN")
    if not d or not os.path.isfile(os.path.join(d, "vo_run")):
        sys.exit("PLANETARY_VO_BIN must name the folder of lunar_render, vo_run and vo_eval (ctest sets it)")
    return d


def output_dir(default_name):
    return os.environ.get("CAMPAIGN_TEST_OUTPUT", os.path.join("/tmp", default_name))


def write_no_ba_config(folder):
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "no_ba.yaml")
    with open(path, "w") as f:
        f.write(NO_BA_YAML)
    return path


def counting_shims(folder, real_bin, calls_dir):
    """A folder of shell shims for lunar_render, vo_run and vo_eval that append their arguments (one call per
    line, separated by the ASCII unit separator) to calls_dir/TOOL and exec the real tool in real_bin."""
    os.makedirs(folder, exist_ok=True)
    os.makedirs(calls_dir, exist_ok=True)
    for tool in ("lunar_render", "vo_run", "vo_eval"):
        path = os.path.join(folder, tool)
        with open(path, "w") as f:
            # One write per call (O_APPEND, a few hundred bytes): calls of concurrent runs never interleave.
            f.write(f"#!/bin/sh\nline=$(printf '%s\\037' \"$@\")\n"
                    f"printf '%s\\n' \"$line\" >> '{calls_dir}/{tool}'\n"
                    f"exec '{os.path.join(real_bin, tool)}' \"$@\"\n")
        os.chmod(path, 0o755)
    return folder


def read_calls(calls_dir):
    """{tool: [argument list of each call]} logged by counting_shims."""
    calls = {}
    for tool in ("lunar_render", "vo_run", "vo_eval"):
        try:
            with open(os.path.join(calls_dir, tool)) as f:
                lines = f.read().split("\n")
        except OSError:
            lines = []
        calls[tool] = [ln.rstrip("\x1f").split("\x1f") for ln in lines if ln]
    return calls


def run_tool(args, timeout=240, env=None):
    """Runs vo_campaign.py; returns the CompletedProcess (stdout and stderr as text)."""
    return subprocess.run([PYTHON, TOOL] + args, capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, env=env)


def read_json(path):
    with open(path) as f:
        return json.load(f)


def close(a, b, rel=1e-9, abs_tol=1e-9):
    if a is None or b is None:
        return a is None and b is None
    return math.isclose(a, b, rel_tol=rel, abs_tol=abs_tol)
