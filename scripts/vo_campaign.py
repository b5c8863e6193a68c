#!/usr/bin/python3
"""Monte Carlo campaign of the VO on one Lunar sequence: N dispersed runs, their statistics and plots.

One command plans the campaign, executes it on this machine (a process pool on all cores) or on a Slurm
cluster (one array task per run), gathers the results and writes the summary (docs/campaigns.md):

  /usr/bin/python3 scripts/vo_campaign.py --sequence approach_down --runs 50 --size 256 --duration 20
        [--configs default,...] [--scheduler local|slurm] [--jobs N] [--seed S] [--name NAME] [--output DIR]
        [--sensors flight|ideal] [--write-docs docs/campaigns/NAME]

Each run draws its dispersions from the campaign seed (terrain seed, DEM and placement rank, Sun elevation and
azimuth, sensor seed, initial state error; distributions in the options below), renders its dataset once with
lunar_render, then for each VO configuration runs vo_run and scores the trajectory with vo_eval twice (Sim(3)
alignment, and first-pose alignment with the initial state error). Every run ends with a status:
  render_failed, vo_crashed (exit code or signal), never_initialised (no tracked frame), lost (coverage below
  90 %), eval_failed, diverged (Sim(3) ATE above 5 % of the path), ok; "missing" when a run left no result.

Files in the campaign folder (default output/campaigns/NAME):
  runs.json                 the plan: every run's dispersed parameters and the exact command lines
  runs/run_NNN/             dataset/, render.json, render.log; CONFIG/result.json (+ logs) per configuration
  summary.md, summary.json, plots/*.png   statistics over the runs (written by every execution and --gather)

Other modes:
  --replay RUN_ID --plan CAMPAIGN/runs.json --output DIR  runs one run alone again, compares with the campaign
  --gather --output CAMPAIGN                                gathers an existing campaign folder only
  --run-one K --plan CAMPAIGN/runs.json                     executes run K of a plan (what a Slurm task runs)
"""
import argparse
import glob
import hashlib
import json
import math
import os
import re
import resource
import shlex
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import time
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.abspath(__file__)
PYTHON = "/usr/bin/python3"
PLAN_FORMAT = "planetary_vo campaign plan 1"
RESULT_FORMAT = "planetary_vo campaign result 1"
SUMMARY_FORMAT = "planetary_vo campaign summary 1"

# Run classification (docs/campaigns.md): a run is lost below this share of processed frames with a pose
# (tracking or recovered), and diverged above this Sim(3) ATE RMSE in % of the path length.
MIN_COVERAGE = 0.9
DIVERGED_ATE_PERCENT = 5.0
FAILURE_STATUSES = ["render_failed", "vo_crashed", "never_initialised", "lost", "eval_failed", "diverged",
                    "missing"]
WORST_RUNS = 5

# Dispersion defaults (the one place they are set; --help and docs/campaigns.md show them).
DEFAULTS = {
    "dems": "apollo15_gld100",
    "placement_ranks": "0-3",
    "sun_elevation": "5,45",
    "sun_azimuth": "0,360",
    "init_position_sigma_m": 10.0,
    "init_attitude_sigma_deg": 0.05,
    "init_scale_sigma_percent": 1.0,
    "first_scale_window_s": 2.0,
}

# The errors the campaign reports: key in vo_eval's first-pose `final`/`series` (or the Sim(3) report), title,
# unit, signed (statistics of a signed error use |x| for the bound, p99 and max; plots show mean +- 3 sigma).
METRICS = [
    ("position_error_m", "position error", "m", False),
    ("position_error_percent", "position error / distance travelled", "%", False),
    ("velocity_error_mps", "velocity error", "m/s", False),
    ("attitude_error_deg", "attitude error", "deg", False),
    ("tilt_error_deg", "tilt error", "deg", False),
    ("scale_error_percent", "scale error", "%", True),
    ("sim3_ate_percent", "Sim(3) ATE RMSE / path length", "%", False),
]
SERIES_METRICS = [m for m in METRICS if m[0] != "sim3_ate_percent"]
# vo_eval JSON keys of each metric in `final` and in `series`, first match wins.
METRIC_KEYS = {
    "position_error_m": ["position_error_m"],
    "position_error_percent": ["position_error_percent_of_distance", "position_error_percent"],
    "velocity_error_mps": ["velocity_error_mps"],
    "attitude_error_deg": ["attitude_error_deg"],
    "tilt_error_deg": ["tilt_error_deg"],
    "scale_error_percent": ["scale_error_percent"],
}


def die(msg, code=1):
    print(f"vo_campaign: {msg}", file=sys.stderr)
    sys.exit(code)


def now_utc():
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def fmt_duration(seconds):
    if seconds is None or not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def available_cores():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def write_json(path, data):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(data, f, indent=1, sort_keys=False, allow_nan=False)
        f.write("\n")
    os.replace(tmp, path)  # readers (gather, progress) never see a half-written file


def read_json(path):
    with open(path) as f:
        return json.load(f)


def display_path(path):
    """Path relative to the repository when inside it (commands that work from a checkout), else absolute."""
    path = os.path.abspath(path)
    rel = os.path.relpath(path, ROOT)
    return path if rel.startswith("..") else rel


def quote_cmd(cmd):
    return " ".join(shlex.quote(str(c)) for c in cmd)


def finite_or_none(x):
    if x is None:
        return None
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


# ------------------------------------------------------------------------------------------------------------
# Dispersions
# ------------------------------------------------------------------------------------------------------------
def parse_range(text, name):
    """'LO,HI' (uniform) or 'V' (fixed) -> (lo, hi)."""
    try:
        parts = [float(p) for p in text.split(",")]
    except ValueError:
        die(f"--{name} takes LO,HI or one value, got '{text}'", 2)
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2 or parts[0] > parts[1]:
        die(f"--{name} takes LO,HI with LO <= HI or one value, got '{text}'", 2)
    return parts


def parse_int_range(text, name):
    m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", text)
    if not m:
        die(f"--{name} takes LO-HI or one integer, got '{text}'", 2)
    lo = int(m.group(1))
    hi = int(m.group(2)) if m.group(2) is not None else lo
    if lo > hi:
        die(f"--{name}: LO > HI in '{text}'", 2)
    return [lo, hi]


def run_uniforms(campaign_seed, index, count=16):
    """`count` uniforms in [0, 1) of run `index`: a SHA-256 stream of (campaign seed, run index). Run k gets
    the same values whatever the number of runs, the Python version or the platform, and each parameter has
    its own fixed slot, so fixing one dispersion leaves the others' draws unchanged."""
    values = []
    block = 0
    while len(values) < count:
        text = f"planetary_vo campaign seed {campaign_seed} run {index} block {block}"
        raw = hashlib.sha256(text.encode()).digest()
        for i in range(0, 32, 8):
            values.append(int.from_bytes(raw[i:i + 8], "little") / 2.0**64)
        block += 1
    return values[:count]


def normal(u, sigma):
    """Gaussian sample from a uniform by the inverse CDF (deterministic, one uniform per sample)."""
    u = min(max(u, 1e-12), 1.0 - 1e-12)
    return statistics.NormalDist(0.0, sigma).inv_cdf(u) if sigma > 0 else 0.0


def draw_run_params(disp, campaign_seed, index):
    """The dispersed parameters of run `index` (docs/campaigns.md, "Dispersions")."""
    u = run_uniforms(campaign_seed, index)
    p = {}
    # Slots: 0 terrain seed, 1 sensor seed, 2 DEM, 3 placement rank, 4 Sun elevation, 5 Sun azimuth,
    # 6-8 initial position error, 9-11 initial attitude error, 12 initial scale error.
    for key, slot in (("terrain_seed", 0), ("sensor_seed", 1)):
        p[key] = disp[key] if disp[key] is not None else 1 + int(u[slot] * (2**31 - 1))
    dems = disp["dems"]
    p["dem"] = dems[min(int(u[2] * len(dems)), len(dems) - 1)]
    lo, hi = disp["placement_ranks"]
    p["placement_rank"] = lo + min(int(u[3] * (hi - lo + 1)), hi - lo)
    lo, hi = disp["sun_elevation_deg"]
    p["sun_elevation_deg"] = round(lo + u[4] * (hi - lo), 2)
    lo, hi = disp["sun_azimuth_deg"]
    p["sun_azimuth_deg"] = round(lo + u[5] * (hi - lo), 2) % 360.0 if hi - lo >= 360.0 else round(
        lo + u[5] * (hi - lo), 2)
    p["initial_position_error_m"] = [round(normal(u[6 + i], disp["init_position_sigma_m"]), 3)
                                     for i in range(3)]
    p["initial_attitude_error_deg"] = [round(normal(u[9 + i], disp["init_attitude_sigma_deg"]), 5)
                                       for i in range(3)]
    p["initial_scale_error_percent"] = round(normal(u[12], disp["init_scale_sigma_percent"]), 4)
    return p


# ------------------------------------------------------------------------------------------------------------
# Tools and their capabilities
# ------------------------------------------------------------------------------------------------------------
def tool_options(path):
    """The long options a tool's --help lists (both tools print their usage there)."""
    try:
        out = subprocess.run([path, "--help"], capture_output=True, text=True, timeout=30,
                             stdin=subprocess.DEVNULL)
    except OSError as e:
        die(f"cannot run {path}: {e}")
    return set(re.findall(r"--[a-z][a-z0-9-]*", out.stdout + out.stderr))


def file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:16]


def git_describe():
    try:
        out = subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"], capture_output=True,
                             text=True, timeout=10)
        return out.stdout.strip() or None
    except OSError:
        return None


# ------------------------------------------------------------------------------------------------------------
# Plan
# ------------------------------------------------------------------------------------------------------------
def is_metric_config(path):
    """True when the configuration enables the IMU or the altimeter (its output is then metric in the handed-over
    world frame): such runs are handed the first true state with the run's initial state error and scored
    without any alignment."""
    section = None
    with open(path) as f:
        for line in f:
            stripped = line.split("#", 1)[0].rstrip()
            if not stripped:
                continue
            if not line[0].isspace():
                section = stripped.rstrip(":").strip()
            elif section in ("imu", "altimeter") and re.fullmatch(r"\s+enabled:\s*true", stripped):
                return True
    return False


def resolve_configs(text):
    configs = []
    for item in [c.strip() for c in text.split(",") if c.strip()]:
        if item.endswith((".yaml", ".yml")) or os.sep in item:
            path = os.path.abspath(item)
            name = os.path.splitext(os.path.basename(item))[0]
        else:
            path = os.path.join(ROOT, "config", item + ".yaml")
            name = item
        if not os.path.isfile(path):
            die(f"configuration {item}: {path} not found", 2)
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", name) or name in [c["name"] for c in configs]:
            die(f"configuration name '{name}' is not usable as a folder name or given twice", 2)
        configs.append({"name": name, "path": path, "metric": is_metric_config(path)})
    if not configs:
        die("--configs names no configuration", 2)
    return configs


def build_plan(args, out_dir, bin_dir):
    tools = {t: os.path.join(bin_dir, t) for t in ("lunar_render", "vo_run", "vo_eval")}
    for name, path in tools.items():
        if not os.access(path, os.X_OK):
            die(f"{name} not found in {bin_dir}: build it first (cmake --build build --target lunar_render "
                f"vo_run vo_eval) or give --bin")
    render_opts = tool_options(tools["lunar_render"])
    eval_opts = tool_options(tools["vo_eval"])
    disp = {
        "terrain_seed": args.terrain_seed,
        "sensor_seed": args.sensor_seed,
        "dems": [d.strip() for d in args.dems.split(",") if d.strip()],
        "placement_ranks": parse_int_range(args.placement_ranks, "placement-ranks"),
        "sun_elevation_deg": parse_range(args.sun_elevation, "sun-elevation"),
        "sun_azimuth_deg": parse_range(args.sun_azimuth, "sun-azimuth"),
        "init_position_sigma_m": args.init_position_sigma_m,
        "init_attitude_sigma_deg": args.init_attitude_sigma_deg,
        "init_scale_sigma_percent": args.init_scale_sigma_percent,
    }
    if not disp["dems"]:
        die("--dems names no DEM", 2)

    # Options this lunar_render build does not know: explicit requests are errors; dispersions that cannot be
    # applied are recorded in the plan and shown in the summary, so a campaign never claims one it lacks.
    not_applied = []
    if "--placement-rank" not in render_opts:
        not_applied.append("placement_rank")
    if "--sensor-seed" not in render_opts:
        not_applied.append("sensor_seed")
    if "--sensors" not in render_opts:
        if args.sensors != "ideal":
            not_applied.append(f"sensors {args.sensors} (this lunar_render has ideal sensors only)")
    for option, value in (("--imu-grade", args.imu_grade), ("--set", args.set)):
        if value and option not in render_opts:
            die(f"this lunar_render has no {option} option (rebuild it)", 2)
    first_pose = "--initial-error-m" in eval_opts
    if not first_pose:
        not_applied.append("initial state error (this vo_eval has no first-pose alignment)")

    configs = resolve_configs(args.configs)
    runs = []
    width = max(3, len(str(args.runs - 1)))
    for k in range(args.runs):
        run_id = f"run_{k:0{width}d}"
        run_dir = os.path.join(out_dir, "runs", run_id)
        p = draw_run_params(disp, args.seed, k)
        dataset = os.path.join(run_dir, "dataset")
        render = [tools["lunar_render"], "--sequence", args.sequence, "--output", dataset,
                  "--width", str(args.size), "--height", str(args.size), "--seed", str(p["terrain_seed"]),
                  "--dem", p["dem"], "--sun-elevation", f"{p['sun_elevation_deg']:g}",
                  "--sun-azimuth", f"{p['sun_azimuth_deg']:g}"]
        if args.duration > 0:
            render += ["--duration", f"{args.duration:g}"]
        if args.rate:
            render += ["--rate", f"{args.rate:g}"]
        if "--placement-rank" in render_opts:
            render += ["--placement-rank", str(p["placement_rank"])]
        if "--sensors" in render_opts:
            render += ["--sensors", args.sensors]
        if "--sensor-seed" in render_opts:
            render += ["--sensor-seed", str(p["sensor_seed"])]
        if args.imu_grade:
            render += ["--imu-grade", args.imu_grade]
        for assignment in args.set or []:
            render += ["--set", assignment]
        if "--no-progress" in render_opts:
            render += ["--no-progress"]
        gt = dataset if first_pose else os.path.join(dataset, "groundtruth.txt")
        per_config = {}
        for c in configs:
            cdir = os.path.join(run_dir, c["name"])
            traj = os.path.join(cdir, "trajectory.txt")
            cmds = {
                "vo_run": [tools["vo_run"], "--dataset", dataset, "--config", c["path"], "--output", traj,
                           "--frame-log", os.path.join(cdir, "frames.log")],
                "eval_sim3": [tools["vo_eval"], "--gt", gt, "--est", traj, "--align", "sim3", "--json",
                              os.path.join(cdir, "eval_sim3.json")],
            }
            pe, ae = p["initial_position_error_m"], p["initial_attitude_error_deg"]
            if c.get("metric"):
                # Metric navigation (IMU / altimeter): handed the first true pose and velocity with the run's
                # initial state error, scored as guidance reads it (no alignment), with its own velocity and
                # covariance.
                velocity, covariance = os.path.join(cdir, "velocity.txt"), os.path.join(cdir, "covariance.txt")
                cmds["vo_run"] += ["--initial-state-from-groundtruth",
                                   "--initial-error-m", ",".join(f"{v:g}" for v in pe),
                                   "--initial-error-deg", ",".join(f"{v:g}" for v in ae),
                                   "--output-velocity", velocity, "--output-covariance", covariance]
                cmds["eval_first"] = [
                    tools["vo_eval"], "--gt", dataset, "--est", traj, "--align", "none",
                    "--est-velocity", velocity, "--est-cov", covariance,
                    "--json", os.path.join(cdir, "eval_first.json")]
            elif first_pose:
                cmds["eval_first"] = [
                    tools["vo_eval"], "--gt", gt, "--est", traj, "--align", "first",
                    "--first-scale-window", f"{args.first_scale_window:g}",
                    "--initial-error-m", ",".join(f"{v:g}" for v in pe),
                    "--initial-error-deg", ",".join(f"{v:g}" for v in ae),
                    "--initial-scale-error", f"{p['initial_scale_error_percent'] / 100.0:.8g}",
                    "--json", os.path.join(cdir, "eval_first.json")]
            per_config[c["name"]] = cmds
        runs.append({"id": run_id, "index": k, "dir": run_dir, "params": p,
                     "commands": {"render": render, "configs": per_config}})

    return {
        "format": PLAN_FORMAT,
        "name": args.name,
        "created_utc": now_utc(),
        "command": [PYTHON, SCRIPT] + sys.argv[1:],
        "git": git_describe(),
        "root": ROOT,
        "script": SCRIPT,
        "output": out_dir,
        "bin": bin_dir,
        "tools": {name: {"path": path, "sha256_16": file_digest(path)} for name, path in tools.items()},
        "sequence": args.sequence,
        "size_px": args.size,
        "duration_s": args.duration,
        "rate_hz": args.rate,
        "sensors": args.sensors,
        "imu_grade": args.imu_grade,
        "render_set": args.set or [],
        "seed": args.seed,
        "configs": configs,
        "dispersions": disp,
        "not_applied": not_applied,
        "eval": {"first_pose": first_pose, "first_scale_window_s": args.first_scale_window,
                 "min_coverage": MIN_COVERAGE, "diverged_ate_percent": DIVERGED_ATE_PERCENT},
        "runs": runs,
    }


def same_runs(plan_a, plan_b):
    """Whether two plans describe the same runs (so that results already in the folder belong to the plan)."""
    keys = ("sequence", "size_px", "duration_s", "rate_hz", "sensors", "imu_grade", "render_set", "configs",
            "runs", "eval")
    return all(plan_a.get(k) == plan_b.get(k) for k in keys)


# ------------------------------------------------------------------------------------------------------------
# Executing one run
# ------------------------------------------------------------------------------------------------------------
def call(cmd, log_path, timeout_s):
    """Runs cmd with its output in log_path: (exit code, wall s, CPU s of the child). The child CPU time is
    the difference of RUSAGE_CHILDREN, exact because this process runs one child at a time. Exit code -N:
    signal N; None: timed out (killed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    with open(log_path, "w") as log:
        log.write(f"$ {quote_cmd(cmd)}\n")
        log.flush()
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        try:
            rc = proc.wait(timeout=timeout_s if timeout_s and timeout_s > 0 else None)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            rc = None
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return rc, wall, cpu


def describe_rc(tool, rc):
    if rc is None:
        return f"{tool} timed out"
    if rc < 0:
        try:
            name = signal.Signals(-rc).name
        except ValueError:
            name = f"signal {-rc}"
        return f"{tool} killed by {name}"
    return f"{tool} exit code {rc}"


def last_error_line(log_path):
    try:
        with open(log_path, errors="replace") as f:
            lines = [ln.strip() for ln in f if ln.strip() and not ln.startswith("$ ")]
    except OSError:
        return ""
    return lines[-1][:200] if lines else ""


def parse_vo_run_log(path):
    """Frame counts from vo_run's summary: processed frames, poses, and the state counts."""
    found = {}
    with open(path, errors="replace") as f:
        for line in f:
            m = re.search(r"(\d+) processed frames.* (\d+) poses ->", line)
            if m:
                found["processed_frames"], found["poses"] = int(m.group(1)), int(m.group(2))
            m = re.search(r"states: initialising (\d+), tracking (\d+), lost (\d+), recovered (\d+)", line)
            if m:
                found["states"] = dict(zip(("initialising", "tracking", "lost", "recovered"),
                                           (int(g) for g in m.groups())))
    if "processed_frames" in found and "states" in found:
        s = found["states"]
        found["coverage"] = (s["tracking"] + s["recovered"]) / max(1, found["processed_frames"])
    return found


def pick(d, keys):
    for k in keys:
        if isinstance(d, dict) and k in d:
            return d[k]
    return None


def eval_metrics(sim3, first):
    """final values and series of the campaign's errors from vo_eval's JSON (docs/evaluation.md): the
    first-pose evaluation gives the navigation errors (`final`, `series`), the Sim(3) one the ATE in % of the
    path."""
    final = {m[0]: None for m in METRICS}
    series = {}
    if sim3 is not None:
        final["sim3_ate_percent"] = finite_or_none(sim3.get("ate_rmse_percent_of_path"))
    if first is not None:
        fin = first.get("final", {})
        for key, names in METRIC_KEYS.items():
            final[key] = finite_or_none(pick(fin, names))
        ser = first.get("series", {})
        t = ser.get("t_rel_s")
        if t:
            series["t_rel_s"] = [finite_or_none(v) for v in t]
            for key, names in METRIC_KEYS.items():
                values = pick(ser, names)
                if values is not None and len(values) == len(t):
                    series[key] = [finite_or_none(v) for v in values]
            if "position_error_percent" not in series and "position_error_m" in series:
                dist = pick(ser, ["distance_m", "distance_travelled_m"])
                if dist is not None and len(dist) == len(t):
                    series["position_error_percent"] = [
                        100.0 * e / d if e is not None and d else None
                        for e, d in zip(series["position_error_m"], dist)]
    return final, series


def classify(render_rc, vo_rc, vo, sim3_rc, final):
    """(status, reason) of one (run, configuration); docs/campaigns.md, "Run status"."""
    if render_rc != 0:
        return "render_failed", describe_rc("lunar_render", render_rc)
    if vo_rc != 0:
        return "vo_crashed", describe_rc("vo_run", vo_rc)
    if "coverage" not in vo:
        return "vo_crashed", "vo_run printed no frame or state counts"
    s = vo["states"]
    if s["tracking"] + s["recovered"] == 0:
        return "never_initialised", f"no tracked frame in {vo['processed_frames']} processed frames"
    if vo["coverage"] < MIN_COVERAGE:
        return "lost", (f"coverage {100 * vo['coverage']:.1f} % < {100 * MIN_COVERAGE:.0f} % "
                        f"(tracking {s['tracking']}, recovered {s['recovered']}, lost {s['lost']}, "
                        f"initialising {s['initialising']})")
    if sim3_rc != 0 or final.get("sim3_ate_percent") is None:
        return "eval_failed", describe_rc("vo_eval --align sim3", sim3_rc) if sim3_rc else "no Sim(3) ATE"
    if final["sim3_ate_percent"] > DIVERGED_ATE_PERCENT:
        return "diverged", (f"Sim(3) ATE {final['sim3_ate_percent']:.2f} % of the path > "
                            f"{DIVERGED_ATE_PERCENT:g} %")
    return "ok", ""


def executor_info():
    info = {"host": socket.gethostname(), "pid": os.getpid()}
    for key in ("SLURM_JOB_ID", "SLURM_ARRAY_JOB_ID", "SLURM_ARRAY_TASK_ID", "SLURM_CPUS_PER_TASK",
                "SLURM_JOB_PARTITION", "SLURM_CLUSTER_NAME"):
        if os.environ.get(key):
            info[key.lower()] = os.environ[key]
    return info


def execute_run(plan, run, render_threads, timeout_s, delete_images=False):
    """Renders the run once, then runs and scores every configuration on it; writes render.json and one
    CONFIG/result.json per configuration into the run folder. Returns the results."""
    run_dir = run["dir"]
    os.makedirs(run_dir, exist_ok=True)
    executor = executor_info()
    render_cmd = list(run["commands"]["render"])
    if render_threads:
        render_cmd += ["--threads", str(render_threads)]
    render_log = os.path.join(run_dir, "render.log")
    r_rc, r_wall, r_cpu = call(render_cmd, render_log, timeout_s)
    cached = False
    summary_line = ""
    try:
        with open(render_log, errors="replace") as f:
            out = [ln.strip() for ln in f if ln.strip() and not ln.startswith("$ ")]
        summary_line = next(
            (ln for ln in reversed(out) if ln.startswith(("rendered", "up to date", "images"))), "")
        cached = summary_line.startswith("up to date")
    except OSError:
        pass
    render = {"rc": r_rc, "cached": cached, "threads": render_threads, "wall_s": round(r_wall, 3),
              "cpu_s": round(r_cpu, 3), "summary": summary_line, "executor": executor,
              "error": "" if r_rc == 0 else last_error_line(render_log)}
    write_json(os.path.join(run_dir, "render.json"), render)

    results = []
    for c in plan["configs"]:
        name = c["name"]
        cmds = run["commands"]["configs"][name]
        cdir = os.path.join(run_dir, name)
        os.makedirs(cdir, exist_ok=True)
        for stale in ("trajectory.txt", "eval_sim3.json", "eval_first.json", "result.json"):
            if os.path.exists(os.path.join(cdir, stale)):
                os.remove(os.path.join(cdir, stale))
        vo, vo_rc, vo_wall, vo_cpu = {}, None, 0.0, 0.0
        sim3 = first = None
        sim3_rc = first_rc = None
        eval_wall = eval_cpu = 0.0
        if r_rc == 0:
            vo_rc, vo_wall, vo_cpu = call(cmds["vo_run"], os.path.join(cdir, "vo_run.log"), timeout_s)
            if vo_rc == 0:
                vo = parse_vo_run_log(os.path.join(cdir, "vo_run.log"))
            if vo_rc == 0 and vo.get("poses", 0) >= 3:
                sim3_rc, w, cpu = call(cmds["eval_sim3"], os.path.join(cdir, "vo_eval_sim3.log"), timeout_s)
                eval_wall += w
                eval_cpu += cpu
                if sim3_rc == 0:
                    sim3 = read_json(os.path.join(cdir, "eval_sim3.json"))
                if "eval_first" in cmds:
                    first_rc, w, cpu = call(cmds["eval_first"], os.path.join(cdir, "vo_eval_first.log"),
                                            timeout_s)
                    eval_wall += w
                    eval_cpu += cpu
                    if first_rc == 0:
                        first = read_json(os.path.join(cdir, "eval_first.json"))
        final, series = eval_metrics(sim3, first)
        status, reason = classify(r_rc, vo_rc, vo, sim3_rc, final)
        if status == "ok" and "eval_first" in cmds and first_rc != 0:
            status, reason = "eval_failed", describe_rc("vo_eval --align first", first_rc)
        result = {
            "format": RESULT_FORMAT,
            "campaign": plan["name"],
            "run_id": run["id"],
            "index": run["index"],
            "config": name,
            "params": run["params"],
            "status": status,
            "reason": reason,
            "vo": vo,
            "final": final,
            "series": series,
            "timing": {"render_wall_s": render["wall_s"], "render_cpu_s": render["cpu_s"],
                       "render_cached": cached, "render_threads": render_threads,
                       "vo_wall_s": round(vo_wall, 3),
                       "vo_cpu_s": round(vo_cpu, 3), "eval_wall_s": round(eval_wall, 3),
                       "eval_cpu_s": round(eval_cpu, 3)},
            "executor": executor,
        }
        write_json(os.path.join(cdir, "result.json"), result)
        results.append(result)
    if delete_images and r_rc == 0:
        shutil.rmtree(os.path.join(run_dir, "dataset", "images"), ignore_errors=True)
    return results


def deterministic_part(result):
    """What must be identical when a run is executed again (timing, host and Slurm ids are not)."""
    return {k: v for k, v in result.items() if k not in ("timing", "executor")}


def result_line(run_id, results, wall_s):
    parts = []
    for r in results:
        text = f"{r['config']} {r['status']}"
        f = r["final"]
        if r["status"] in ("ok", "diverged"):
            if f.get("position_error_m") is not None:
                text += f" {f['position_error_m']:.2f} m"
            elif f.get("sim3_ate_percent") is not None:
                text += f" ATE {f['sim3_ate_percent']:.2f} %"
        parts.append(text)
    return f"{run_id}  {', '.join(parts)}  ({wall_s:.1f} s)"


# ------------------------------------------------------------------------------------------------------------
# Schedulers
# ------------------------------------------------------------------------------------------------------------
def result_paths(plan, run):
    return [os.path.join(run["dir"], c["name"], "result.json") for c in plan["configs"]]


def run_complete(plan, run, since=0.0):
    paths = result_paths(plan, run)
    return all(os.path.exists(p) and os.path.getmtime(p) >= since for p in paths)


def load_run_results(plan, run):
    out = []
    for p in result_paths(plan, run):
        try:
            out.append(read_json(p))
        except (OSError, ValueError):
            pass
    return out


class Progress:
    """One line per finished run with the elapsed time and an ETA (plain lines: works without a terminal)."""

    def __init__(self, total):
        self.total = total
        self.done = 0
        self.start = time.monotonic()
        self.width = len(str(total))

    def finished(self, text):
        self.done += 1
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        print(f"[{self.done:>{self.width}}/{self.total}] {text}  elapsed {fmt_duration(elapsed)}  "
              f"ETA {fmt_duration(eta)}", flush=True)


def execute_local(plan, plan_path, jobs, render_threads, timeout_s, delete_images):
    """A pool of `jobs` concurrent `--run-one` processes (the same code a Slurm task runs)."""
    runs = plan["runs"]
    progress = Progress(len(runs))
    pending = list(range(len(runs)))
    active = {}  # pid -> (index, Popen, start, log file)
    failed_tasks = []
    try:
        while pending or active:
            while pending and len(active) < jobs:
                k = pending.pop(0)
                os.makedirs(runs[k]["dir"], exist_ok=True)
                log = open(os.path.join(runs[k]["dir"], "task.log"), "w")
                cmd = [PYTHON, SCRIPT, "--run-one", str(k), "--plan", plan_path, "--render-threads",
                       str(render_threads), "--tool-timeout", str(timeout_s)]
                if delete_images:
                    cmd.append("--delete-images")
                proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
                active[proc.pid] = (k, proc, time.monotonic(), log)
            pid, status = os.wait()
            if pid not in active:
                continue
            k, proc, start, log = active.pop(pid)
            proc.returncode = os.waitstatus_to_exitcode(status)
            log.close()
            run = runs[k]
            if proc.returncode != 0:
                failed_tasks.append(run["id"])
                why = describe_rc("vo_campaign --run-one", proc.returncode)
                log_path = display_path(os.path.join(run["dir"], "task.log"))
                progress.finished(f"{run['id']}  task failed ({why}, see {log_path})")
            else:
                wall = time.monotonic() - start
                progress.finished(result_line(run["id"], load_run_results(plan, run), wall))
    except KeyboardInterrupt:
        for k, proc, _, _ in active.values():
            proc.terminate()
        for k, proc, _, _ in active.values():
            proc.wait()
        raise
    return failed_tasks


def slurm_tool(name):
    path = shutil.which(name)
    if not path:
        die(f"{name} not found: the Slurm scheduler needs the Slurm client commands (Debian: slurm-client)")
    return path


def write_sbatch_script(plan, plan_path, args):
    slurm_dir = os.path.join(plan["output"], "slurm")
    logs = os.path.join(slurm_dir, "logs")
    os.makedirs(logs, exist_ok=True)
    n = len(plan["runs"])
    array = f"0-{n - 1}" + (f"%{args.array_limit}" if args.array_limit else "")
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", plan["name"])[:60]
    delete = " --delete-images" if args.delete_images else ""
    script = f"""#!/bin/bash
# Written by scripts/vo_campaign.py: one array task per Monte Carlo run of campaign {plan['name']}.
# Task K renders run K once and runs every VO configuration on it (vo_campaign.py --run-one K); the
# results appear as runs/run_NNN/CONFIG/result.json in the campaign folder, which must be on a filesystem
# shared by the submitting host and the compute nodes (so must the build folder and the shared data).
#SBATCH --job-name=vo_campaign_{name}
#SBATCH --array={array}
#SBATCH --cpus-per-task={args.cpus_per_task}
#SBATCH --output={logs}/task_%a.out
#SBATCH --chdir={plan['output']}
set -eu
echo "vo_campaign task: SLURM_JOB_ID=$SLURM_JOB_ID SLURM_ARRAY_JOB_ID=$SLURM_ARRAY_JOB_ID \\
SLURM_ARRAY_TASK_ID=$SLURM_ARRAY_TASK_ID host=$(hostname) cpus=${{SLURM_CPUS_PER_TASK:-1}}"
exec {PYTHON} {shlex.quote(SCRIPT)} --run-one "$SLURM_ARRAY_TASK_ID" --plan {shlex.quote(plan_path)} \\
    --render-threads "${{SLURM_CPUS_PER_TASK:-1}}" --tool-timeout {args.tool_timeout}{delete}
"""
    path = os.path.join(slurm_dir, "campaign.sbatch")
    with open(path, "w") as f:
        f.write(script)
    os.chmod(path, 0o755)
    return path


def squeue_active(squeue, job_id):
    """True while any task of the array is pending or running; None when squeue failed."""
    out = subprocess.run([squeue, "-h", "-j", job_id, "-o", "%i %T"], capture_output=True, text=True,
                         timeout=60, stdin=subprocess.DEVNULL)
    if out.returncode != 0:
        if "Invalid job id" in out.stderr:
            return False  # finished and already purged from the controller
        return None
    return bool(out.stdout.strip())


def execute_slurm(plan, plan_path, args):
    """Submits the plan as one array job and waits for it; progress from the result files appearing."""
    sbatch, squeue, scancel = slurm_tool("sbatch"), slurm_tool("squeue"), slurm_tool("scancel")
    script = write_sbatch_script(plan, plan_path, args)
    cmd = [sbatch, "--parsable"] + shlex.split(args.slurm_args or "") + [script]
    submitted = time.time()
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    if out.returncode != 0:
        die(f"sbatch failed ({out.returncode}): {out.stderr.strip()}\n  command: {quote_cmd(cmd)}")
    job_id = out.stdout.strip().split(";")[0]
    conf = os.environ.get("SLURM_CONF", "the default slurm.conf")
    print(f"vo_campaign: submitted array job {job_id} ({len(plan['runs'])} tasks, {conf}): {quote_cmd(cmd)}",
          flush=True)
    with open(os.path.join(plan["output"], "slurm", "job_id.txt"), "w") as f:
        f.write(job_id + "\n")
    progress = Progress(len(plan["runs"]))
    reported = set()
    squeue_failures = 0
    deadline = time.monotonic() + args.slurm_timeout if args.slurm_timeout > 0 else None

    def report_new():
        for run in plan["runs"]:
            if run["id"] not in reported and run_complete(plan, run, since=submitted - 1.0):
                reported.add(run["id"])
                results = load_run_results(plan, run)
                wall = sum(r["timing"]["render_wall_s"] / max(1, len(results)) + r["timing"]["vo_wall_s"] +
                           r["timing"]["eval_wall_s"] for r in results)
                task = results[0]["executor"].get("slurm_job_id", "?") if results else "?"
                progress.finished(result_line(run["id"], results, wall) + f"  [job {task}]")

    try:
        while True:
            time.sleep(args.poll_interval)
            report_new()
            active = squeue_active(squeue, job_id)
            if active is None:
                squeue_failures += 1
                if squeue_failures >= 10:
                    die(f"squeue keeps failing for job {job_id}; the campaign folder can be gathered later "
                        f"with --gather")
                continue
            squeue_failures = 0
            if not active:
                break
            if deadline and time.monotonic() > deadline:
                subprocess.run([scancel, job_id], timeout=60)
                die(f"array job {job_id} still running after --slurm-timeout {args.slurm_timeout:g} s: "
                    f"cancelled")
    except KeyboardInterrupt:
        subprocess.run([scancel, job_id], timeout=60)
        print(f"vo_campaign: interrupted, array job {job_id} cancelled", file=sys.stderr)
        raise
    report_new()
    return job_id, [r["id"] for r in plan["runs"] if r["id"] not in reported]


# ------------------------------------------------------------------------------------------------------------
# Statistics
# ------------------------------------------------------------------------------------------------------------
def value_stats(values, signed):
    """Statistics of one error over the runs: mean and (sample) standard deviation of the value, the 3-sigma
    bound |mean| + 3 std, the 99th percentile (linear interpolation between order statistics, numpy's default)
    and the max of |value|."""
    import numpy as np

    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return {"n": 0, "mean": None, "std": None, "bound_3sigma": None, "p99": None, "max": None}
    a = np.abs(v) if signed else v
    mean = float(np.mean(v))
    std = float(np.std(v, ddof=1)) if v.size > 1 else None
    return {"n": int(v.size), "mean": mean, "std": std,
            "bound_3sigma": abs(mean) + 3.0 * std if std is not None else None,
            "p99": float(np.percentile(a, 99)), "max": float(np.max(a))}


def time_grid(results):
    """A common grid of t_rel: from 0 to the longest series, step = the median sample period of the series."""
    import numpy as np

    periods, t_max = [], 0.0
    for r in results:
        t = [x for x in r["series"].get("t_rel_s", []) if x is not None]
        if len(t) >= 2:
            periods.append(float(np.median(np.diff(t))))
            t_max = max(t_max, t[-1])
    if not periods:
        return np.array([])
    step = float(np.median(periods))
    if step <= 0:
        return np.array([])
    return np.arange(0.0, t_max + 0.5 * step, step)


def resample(t, values, grid):
    """Linear interpolation of one run's series on the grid; NaN outside the run's span and next to missing
    samples (a NaN neighbour makes the interpolated value NaN)."""
    import numpy as np

    t = np.array([np.nan if x is None else x for x in t], dtype=float)
    v = np.array([np.nan if x is None else x for x in values], dtype=float)
    keep = np.isfinite(t)
    t, v = t[keep], v[keep]
    out = np.full(grid.shape, np.nan)
    if t.size < 2:
        return out
    inside = (grid >= t[0] - 1e-9) & (grid <= t[-1] + 1e-9)
    idx = np.clip(np.searchsorted(t, grid[inside], side="right") - 1, 0, t.size - 2)
    t0, t1 = t[idx], t[idx + 1]
    w = np.where(t1 > t0, (grid[inside] - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    out[inside] = v[idx] * (1.0 - w) + v[idx + 1] * w
    return out


def series_stats(results, key, signed, grid):
    """Per grid time over the runs with a value there: n, mean, std, mean + 3 std (and mean - 3 std for a
    signed error), p99 (p1 too for a signed error). Runs are resampled on the grid first."""
    import numpy as np

    rows = []
    for r in results:
        s = r["series"]
        if key in s and "t_rel_s" in s:
            rows.append(resample(s["t_rel_s"], s[key], grid))
    if not rows or grid.size == 0:
        return None, None
    m = np.vstack(rows)
    n = np.sum(np.isfinite(m), axis=0)
    with np.errstate(invalid="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", category=RuntimeWarning)
            mean = np.nanmean(m, axis=0)
            std = np.where(n > 1, np.nanstd(m, axis=0, ddof=1) if m.shape[0] > 1 else np.nan, np.nan)
            p99 = np.nanpercentile(m, 99, axis=0)
            p1 = np.nanpercentile(m, 1, axis=0)
    out = {"n": n.tolist(), "mean": mean, "std": std, "upper_3sigma": mean + 3 * std, "p99": p99}
    if signed:
        out["lower_3sigma"] = mean - 3 * std
        out["p1"] = p1
    return out, m


def to_list(a):
    import numpy as np

    return [None if not np.isfinite(x) else round(float(x), 6) for x in np.asarray(a, dtype=float)]


def gather_results(plan):
    """Every (run, configuration) result of the plan; a missing result file becomes status "missing"."""
    results = []
    for run in plan["runs"]:
        for c in plan["configs"]:
            path = os.path.join(run["dir"], c["name"], "result.json")
            try:
                r = read_json(path)
                if r.get("run_id") != run["id"] or r.get("config") != c["name"]:
                    raise ValueError(f"{path} belongs to {r.get('run_id')}/{r.get('config')}")
            except (OSError, ValueError) as e:
                r = {"format": RESULT_FORMAT, "campaign": plan["name"], "run_id": run["id"],
                     "index": run["index"], "config": c["name"], "params": run["params"], "status": "missing",
                     "reason": f"no result ({e.__class__.__name__}: the run did not finish)", "vo": {},
                     "final": {m[0]: None for m in METRICS}, "series": {}, "timing": {}, "executor": {}}
            results.append(r)
    return results


def replay_command(plan, run_id):
    return (f"{PYTHON} {display_path(SCRIPT)} --replay {run_id} --plan "
            f"{display_path(os.path.join(plan['output'], 'runs.json'))} --output "
            f"{display_path(os.path.join(ROOT, 'output', 'replay', plan['name'], run_id))}")


def summarize(plan, results, state):
    """summary.json content: per configuration the failure rate and reasons, the statistics of the final
    errors and against time, the worst runs; the timing of the campaign."""
    summary = {"format": SUMMARY_FORMAT, "campaign": plan["name"], "created_utc": now_utc(),
               "sequence": plan["sequence"], "size_px": plan["size_px"], "duration_s": plan["duration_s"],
               "sensors": plan["sensors"], "seed": plan["seed"], "runs": len(plan["runs"]),
               "configs": {}, "not_applied": plan.get("not_applied", []),
               "definitions": {"min_coverage": MIN_COVERAGE, "diverged_ate_percent": DIVERGED_ATE_PERCENT,
                               "statistics_over": "runs with status ok",
                               "bound_3sigma": "|mean| + 3 * sample standard deviation",
                               "p99": "99th percentile of |value|, linear interpolation (numpy.percentile)"}}
    for c in plan["configs"]:
        name = c["name"]
        rs = [r for r in results if r["config"] == name]
        ok = [r for r in rs if r["status"] == "ok"]
        counts = {s: sum(1 for r in rs if r["status"] == s) for s in ["ok"] + FAILURE_STATUSES}
        failures = [{"run_id": r["run_id"], "status": r["status"], "reason": r["reason"],
                     "replay": replay_command(plan, r["run_id"])} for r in rs if r["status"] != "ok"]
        final_stats = {m[0]: value_stats([r["final"].get(m[0]) for r in ok], m[3]) for m in METRICS}
        grid = time_grid(ok)
        series = {"t_rel_s": to_list(grid)}
        for key, _, _, signed in SERIES_METRICS:
            st, _ = series_stats(ok, key, signed, grid)
            if st is not None:
                series[key] = {k: (v if k == "n" else to_list(v)) for k, v in st.items()}
        rank_key = "position_error_m" if any(r["final"].get("position_error_m") is not None for r in rs) \
            else "sim3_ate_percent"
        ranked = sorted([r for r in rs if r["final"].get(rank_key) is not None],
                        key=lambda r: (-r["final"][rank_key], r["run_id"]))
        worst = [{"run_id": r["run_id"], "status": r["status"], rank_key: r["final"][rank_key],
                  "final": r["final"], "params": r["params"], "replay": replay_command(plan, r["run_id"])}
                 for r in ranked[:WORST_RUNS]]
        summary["configs"][name] = {
            "runs": len(rs), "counts": counts, "ok": len(ok),
            "failure_rate": (len(rs) - len(ok)) / len(rs) if rs else None,
            "failures": failures, "final": final_stats, "series": series,
            "worst_by": rank_key, "worst": worst,
            "vo_wall_s": value_stats([r["timing"].get("vo_wall_s") for r in rs if r["timing"]], False),
            "vo_cpu_s": value_stats([r["timing"].get("vo_cpu_s") for r in rs if r["timing"]], False),
            "eval_wall_s": value_stats([r["timing"].get("eval_wall_s") for r in rs if r["timing"]], False),
        }
    renders = []
    for run in plan["runs"]:
        try:
            renders.append(read_json(os.path.join(run["dir"], "render.json")))
        except (OSError, ValueError):
            pass
    fresh = [r for r in renders if not r.get("cached") and r.get("rc") == 0]
    n_cfg = len(plan["configs"])
    vo_cpu_total = sum(r["timing"].get("vo_cpu_s", 0.0) for r in results if r["timing"])
    eval_cpu_total = sum(r["timing"].get("eval_cpu_s", 0.0) for r in results if r["timing"])
    render_cpu_total = sum(r["cpu_s"] for r in renders)
    summary["timing"] = {
        "renders": len(renders), "renders_cached": sum(1 for r in renders if r.get("cached")),
        "vo_runs": sum(1 for r in results if r["timing"].get("vo_wall_s")),
        "configs_per_render": n_cfg,
        "render_wall_s": value_stats([r["wall_s"] for r in fresh], False),
        "render_cpu_s": value_stats([r["cpu_s"] for r in fresh], False),
        "render_cpu_total_s": round(render_cpu_total, 2),
        "vo_cpu_total_s": round(vo_cpu_total, 2),
        "eval_cpu_total_s": round(eval_cpu_total, 2),
        # Without the shared render every configuration would render its own copy of the run.
        "render_cpu_saved_s": round(render_cpu_total * (n_cfg - 1), 2),
        "campaign": state,
    }
    return summary


# ------------------------------------------------------------------------------------------------------------
# Report: plots and summary.md
# ------------------------------------------------------------------------------------------------------------
def make_plots(plan, results, summary, plots_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    os.makedirs(plots_dir, exist_ok=True)
    for old in glob.glob(os.path.join(plots_dir, "*.png")):
        os.remove(old)
    names = [c["name"] for c in plan["configs"]]
    written = []
    title = f"{plan['name']}: {plan['sequence']} {plan['size_px']} px, {len(plan['runs'])} runs"
    for key, label, unit, signed in SERIES_METRICS:
        have = [n for n in names if key in summary["configs"][n]["series"]]
        if not have:
            continue
        fig, axes = plt.subplots(1, len(have), figsize=(6.5 * len(have), 4.2), squeeze=False, sharey=True)
        for ax, name in zip(axes[0], have):
            ok = [r for r in results if r["config"] == name and r["status"] == "ok"]
            grid = np.array([np.nan if x is None else x
                             for x in summary["configs"][name]["series"]["t_rel_s"]])
            st = summary["configs"][name]["series"][key]
            for r in ok:
                s = r["series"]
                if key in s:
                    t = np.array([np.nan if x is None else x for x in s["t_rel_s"]], dtype=float)
                    v = np.array([np.nan if x is None else x for x in s[key]], dtype=float)
                    ax.plot(t, v, color="tab:blue", alpha=0.25, linewidth=0.7)
            arr = {k: np.array([np.nan if x is None else x for x in v], dtype=float)
                   for k, v in st.items() if k != "n"}
            ax.plot(grid, arr["mean"], color="black", linewidth=1.6, label="mean")
            ax.plot(grid, arr["upper_3sigma"], color="tab:red", linewidth=1.3, linestyle="--",
                    label="mean + 3 sigma")
            ax.plot(grid, arr["p99"], color="tab:orange", linewidth=1.3, label="p99")
            if signed:
                ax.plot(grid, arr["lower_3sigma"], color="tab:red", linewidth=1.3, linestyle="--",
                        label="mean - 3 sigma")
                ax.plot(grid, arr["p1"], color="tab:orange", linewidth=1.3, linestyle=":", label="p1")
                ax.axhline(0.0, color="gray", linewidth=0.6)
            ax.set_title(f"{name} ({len(ok)} ok runs)", fontsize=9)
            ax.set_xlabel("time since the first pose [s]")
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7)
        axes[0][0].set_ylabel(f"{label} [{unit}]")
        fig.suptitle(f"{title}: {label}", fontsize=10)
        fig.tight_layout()
        path = os.path.join(plots_dir, f"{key}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    # Histogram of the final position error (or of the Sim(3) ATE when there is no first-pose evaluation).
    hist_key = "position_error_m" if any(r["final"].get("position_error_m") is not None for r in results) \
        else "sim3_ate_percent"
    hist_label, hist_unit = {m[0]: (m[1], m[2]) for m in METRICS}[hist_key]
    fig, ax = plt.subplots(figsize=(7, 4))
    for name in names:
        vals = [r["final"][hist_key] for r in results
                if r["config"] == name and r["status"] == "ok" and r["final"].get(hist_key) is not None]
        if vals:
            ax.hist(vals, bins=max(5, min(30, len(vals) // 2)), histtype="step", linewidth=1.5,
                    label=f"{name} ({len(vals)} ok runs)")
    ax.set_xlabel(f"final {hist_label} [{hist_unit}]")
    ax.set_ylabel("runs")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{title}: final {hist_label}", fontsize=10)
    fig.tight_layout()
    path = os.path.join(plots_dir, "final_error_histogram.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    # Outcome of the runs per configuration.
    statuses = ["ok"] + FAILURE_STATUSES
    colors = ["tab:green", "black", "tab:red", "tab:purple", "tab:orange", "tab:gray", "tab:brown",
              "tab:pink"]
    fig, ax = plt.subplots(figsize=(max(5, 1.6 * len(names) + 3), 3.6))
    bottom = np.zeros(len(names))
    for status, color in zip(statuses, colors):
        counts = np.array([summary["configs"][n]["counts"][status] for n in names], dtype=float)
        if counts.sum() > 0:
            ax.bar(names, counts, bottom=bottom, color=color, label=status)
            bottom += counts
    ax.set_ylabel("runs")
    ax.legend(fontsize=8, bbox_to_anchor=(1.02, 1), loc="upper left")
    ax.set_title(f"{title}: outcome", fontsize=10)
    fig.tight_layout()
    path = os.path.join(plots_dir, "outcome.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
    return written


def fmt(x, digits=3):
    if x is None:
        return "-"
    if abs(x) >= 1000:
        return f"{x:.0f}"
    return f"{x:.{digits}g}" if abs(x) < 1e-3 and x != 0 else f"{x:.{digits}f}"


def write_markdown(plan, summary, path, plots):
    d = plan["dispersions"]
    lines = [f"# Monte Carlo campaign {plan['name']}", ""]
    lines += [f"{len(plan['runs'])} runs of `{plan['sequence']}` at {plan['size_px']}x{plan['size_px']} px, "
              f"{plan['duration_s']:g} s, {plan['sensors']} sensors, campaign seed {plan['seed']}, "
              f"configurations {', '.join(c['name'] for c in plan['configs'])}. "
              f"Code {plan.get('git') or '?'}.",
              "", "```sh", quote_cmd([PYTHON, display_path(SCRIPT)] + plan["command"][2:]), "```", ""]
    if plan.get("not_applied"):
        lines += ["**Not applied** (the tools built here lack them): " + "; ".join(plan["not_applied"]) + ".",
                  ""]
    lines += ["## Dispersions", "", "| parameter | distribution |", "|---|---|"]
    lines.append("| terrain seed | " + (f"fixed {d['terrain_seed']}" if d["terrain_seed"] is not None
                                       else "uniform 1..2^31-1") + " |")
    lines.append("| DEM | uniform over " + ", ".join(d["dems"]) + " |")
    lines.append(f"| DEM placement rank | uniform {d['placement_ranks'][0]}..{d['placement_ranks'][1]} |")
    el = d["sun_elevation_deg"]
    lines.append(f"| Sun elevation | uniform {el[0]:g}..{el[1]:g} deg |")
    lines.append(f"| Sun azimuth | uniform {d['sun_azimuth_deg'][0]:g}..{d['sun_azimuth_deg'][1]:g} deg |")
    sensor = f"fixed {d['sensor_seed']}" if d["sensor_seed"] is not None else "uniform 1..2^31-1"
    lines.append(f"| sensor seed (noise, biases, defects, calibration, camera-IMU misalignment) | {sensor} |")
    lines.append(f"| initial position error | normal, sigma {d['init_position_sigma_m']:g} m per axis |")
    lines.append(f"| initial attitude error | normal, sigma {d['init_attitude_sigma_deg']:g} deg per axis |")
    lines.append(f"| initial scale error | normal, sigma {d['init_scale_sigma_percent']:g} % |")
    lines.append("")
    lines += ["## Outcome", "", "| configuration | runs | ok | failure rate | " +
              " | ".join(FAILURE_STATUSES) + " |", "|---|---|---|---|" + "---|" * len(FAILURE_STATUSES)]
    for name, cs in summary["configs"].items():
        rate = f"{100 * cs['failure_rate']:.1f} %" if cs["failure_rate"] is not None else "-"
        lines.append(f"| {name} | {cs['runs']} | {cs['ok']} | {rate} | " +
                     " | ".join(str(cs["counts"][s]) for s in FAILURE_STATUSES) + " |")
    lines += ["", f"Run status: lost = fewer than {100 * MIN_COVERAGE:.0f} % of the processed frames tracked "
              f"or recovered; diverged = Sim(3) ATE above {DIVERGED_ATE_PERCENT:g} % of the path "
              "(docs/campaigns.md).", ""]
    for name, cs in summary["configs"].items():
        lines += [f"## {name}: errors at the end of the clip (low gate), over the {cs['ok']} ok runs", "",
                  "| error | n | mean | std | 3-sigma bound | p99 | max |", "|---|---|---|---|---|---|---|"]
        for key, label, unit, signed in METRICS:
            s = cs["final"][key]
            if s["n"] == 0:
                continue
            lines.append(f"| {label} [{unit}]{' (signed)' if signed else ''} | {s['n']} | {fmt(s['mean'])} | "
                         f"{fmt(s['std'])} | {fmt(s['bound_3sigma'])} | {fmt(s['p99'])} | {fmt(s['max'])} |")
        lines += ["", "3-sigma bound = |mean| + 3 std (sample std); p99 and max of |value|.", ""]
        if cs["worst"]:
            label, unit = {m[0]: (m[1], m[2]) for m in METRICS}[cs["worst_by"]]
            lines += [f"Worst runs by final {label} [{unit}]:", "",
                      "| run | status | value | terrain seed | DEM / rank | Sun el / az deg | sensor seed |",
                      "|---|---|---|---|---|---|---|"]
            for w in cs["worst"]:
                p = w["params"]
                lines.append(f"| {w['run_id']} | {w['status']} | {fmt(w[cs['worst_by']])} | "
                             f"{p['terrain_seed']} | {p['dem']} / {p['placement_rank']} | "
                             f"{p['sun_elevation_deg']:g} / {p['sun_azimuth_deg']:g} | {p['sensor_seed']} |")
            lines += ["", "Replay one alone:", "", "```sh"] + [w["replay"] for w in cs["worst"]] + ["```", ""]
        if cs["failures"]:
            lines += ["Failed runs:", "", "| run | status | reason |", "|---|---|---|"]
            lines += [f"| {f['run_id']} | {f['status']} | {f['reason']} |" for f in cs["failures"]]
            lines += ["", "```sh"] + [f["replay"] for f in cs["failures"][:10]] + ["```", ""]
    if plots:
        lines += ["## Plots", "", "Every ok run faint; mean, mean + 3 sigma and p99 over the runs at each "
                  "time (runs resampled on a common grid of the time since the first pose).", ""]
        for p in plots:
            lines.append(f"![{os.path.basename(p)}](plots/{os.path.basename(p)})")
        lines.append("")
    t = summary["timing"]
    camp = t.get("campaign") or {}
    lines += ["## Timing", "", "| item | value |", "|---|---|"]
    rw, rc = t["render_wall_s"], t["render_cpu_s"]
    lines.append(f"| renders | {t['renders']} ({t['renders_cached']} cached), one per run, shared by "
                 f"{t['configs_per_render']} configuration(s) |")
    if rw["n"]:
        lines.append(f"| render per run (fresh) | wall mean {fmt(rw['mean'], 2)} s "
                     f"(max {fmt(rw['max'], 2)}), CPU mean {fmt(rc['mean'], 2)} s |")
    for name, cs in summary["configs"].items():
        if cs["vo_wall_s"]["n"]:
            lines.append(f"| vo_run {name} | wall mean {fmt(cs['vo_wall_s']['mean'], 2)} s, CPU mean "
                         f"{fmt(cs['vo_cpu_s']['mean'], 2)} s; vo_eval wall mean "
                         f"{fmt(cs['eval_wall_s']['mean'], 2)} s |")
    lines.append(f"| CPU total | render {t['render_cpu_total_s']:.1f} s, VO {t['vo_cpu_total_s']:.1f} s, "
                 f"eval {t['eval_cpu_total_s']:.1f} s; rendering once for all configurations saved "
                 f"{t['render_cpu_saved_s']:.1f} s |")
    if camp:
        if camp.get("scheduler") == "slurm":
            how = (f"Slurm array job {camp.get('slurm_job_id')}, {camp.get('render_threads')} CPU(s) per "
                   f"task; submitting host")
        else:
            how = (f"local, {camp.get('concurrency', '?')} runs at once, {camp.get('render_threads', '?')} "
                   f"render thread(s) each")
        lines.append(f"| campaign wall | {fmt_duration(camp.get('wall_s'))} ({how}: load average "
                     f"{camp.get('load_average_start')} at the start, {camp.get('load_average_end')} at the "
                     f"end, {camp.get('cores')} cores) |")
    lines.append("")
    with open(path, "w") as f:
        f.write("\n".join(lines))


def write_report(plan, out_dir, state):
    results = gather_results(plan)
    summary = summarize(plan, results, state)
    plots = make_plots(plan, results, summary, os.path.join(out_dir, "plots"))
    summary["plots"] = [os.path.relpath(p, out_dir) for p in plots]
    write_json(os.path.join(out_dir, "summary.json"), summary)
    write_markdown(plan, summary, os.path.join(out_dir, "summary.md"), plots)
    return summary


def print_summary(plan, summary, out_dir):
    print(f"\ncampaign {plan['name']}: {len(plan['runs'])} runs -> {display_path(out_dir)}/summary.md")
    if plan.get("not_applied"):
        print("  not applied: " + "; ".join(plan["not_applied"]))
    for name, cs in summary["configs"].items():
        rate = 100 * cs["failure_rate"] if cs["failure_rate"] is not None else float("nan")
        reasons = ", ".join(f"{s} {n}" for s, n in cs["counts"].items() if s != "ok" and n)
        print(f"  {name}: {cs['ok']}/{cs['runs']} ok, failure rate {rate:.1f} %" +
              (f" ({reasons})" if reasons else ""))
        for key, label, unit, _ in METRICS:
            s = cs["final"][key]
            if s["n"]:
                print(f"    final {label:38s} mean {fmt(s['mean']):>8} std {fmt(s['std']):>8} "
                      f"3sigma {fmt(s['bound_3sigma']):>8} p99 {fmt(s['p99']):>8} max {fmt(s['max']):>8} "
                      f"{unit}")
        for w in cs["worst"]:
            print(f"    worst {w['run_id']} ({w['status']}, {cs['worst_by']} {fmt(w[cs['worst_by']])}): "
                  f"{w['replay']}")
        for f in cs["failures"][:WORST_RUNS]:
            print(f"    failed {f['run_id']} {f['status']}: {f['reason']}")
    t = summary["timing"]
    camp = t.get("campaign") or {}
    rc = t["render_cpu_s"]
    print(f"  timing: {t['renders']} renders ({t['renders_cached']} cached) for {t['vo_runs']} VO runs; "
          f"render CPU {t['render_cpu_total_s']:.1f} s (mean {fmt(rc['mean'], 2)} s per fresh render), "
          f"VO CPU "
          f"{t['vo_cpu_total_s']:.1f} s, eval CPU {t['eval_cpu_total_s']:.1f} s; campaign wall "
          f"{fmt_duration(camp.get('wall_s'))}")


def write_docs(out_dir, docs_dir):
    os.makedirs(os.path.join(docs_dir, "plots"), exist_ok=True)
    for old in glob.glob(os.path.join(docs_dir, "plots", "*.png")):
        os.remove(old)
    for name in ("summary.md", "summary.json"):
        shutil.copy2(os.path.join(out_dir, name), os.path.join(docs_dir, name))
    for p in glob.glob(os.path.join(out_dir, "plots", "*.png")):
        shutil.copy2(p, os.path.join(docs_dir, "plots", os.path.basename(p)))
    print(f"vo_campaign: summary and plots copied to {display_path(docs_dir)}")


# ------------------------------------------------------------------------------------------------------------
# Modes
# ------------------------------------------------------------------------------------------------------------
def load_plan(path):
    try:
        plan = read_json(path)
    except (OSError, ValueError) as e:
        die(f"cannot read the plan {path}: {e}")
    if plan.get("format") != PLAN_FORMAT:
        die(f"{path} is not a campaign plan ({plan.get('format')})")
    return plan


def mode_run_one(args):
    plan = load_plan(args.plan)
    if not 0 <= args.run_one < len(plan["runs"]):
        die(f"--run-one {args.run_one}: the plan has runs 0..{len(plan['runs']) - 1}")
    run = plan["runs"][args.run_one]
    start = time.monotonic()
    results = execute_run(plan, run, args.render_threads or 1, args.tool_timeout, args.delete_images)
    print(result_line(run["id"], results, time.monotonic() - start), flush=True)
    return 0


def rewrite_run(run, new_dir, old_bin=None, new_bin=None):
    """The run with its folder (and optionally its tools' folder) moved: every command argument that starts
    with the old path gets the new one."""
    old_dir = run["dir"]

    def fix(arg):
        if arg == old_dir or arg.startswith(old_dir + os.sep):
            return new_dir + arg[len(old_dir):]
        if old_bin and new_bin and arg.startswith(old_bin + os.sep):
            return new_bin + arg[len(old_bin):]
        return arg

    cmds = run["commands"]
    return dict(run, dir=new_dir, commands={
        "render": [fix(a) for a in cmds["render"]],
        "configs": {c: {k: [fix(a) for a in v] for k, v in d.items()} for c, d in cmds["configs"].items()}})


def mode_replay(args):
    if not args.plan:
        die("--replay needs --plan CAMPAIGN/runs.json", 2)
    plan = load_plan(args.plan)
    match = [r for r in plan["runs"] if r["id"] == args.replay or str(r["index"]) == args.replay]
    if not match:
        die(f"no run {args.replay} in {args.plan}")
    run = match[0]
    out_dir = os.path.abspath(args.output or os.path.join(ROOT, "output", "replay", plan["name"], run["id"]))
    if os.path.abspath(out_dir) == os.path.abspath(run["dir"]):
        die("--output must not be the run's own folder in the campaign", 2)
    new_bin = os.path.abspath(args.bin) if args.bin else None
    replayed = rewrite_run(run, out_dir, plan["bin"], new_bin)
    print(f"vo_campaign: replaying {run['id']} of {plan['name']} into {display_path(out_dir)}")
    print(f"  render: {quote_cmd(replayed['commands']['render'])}")
    for name, cmds in replayed["commands"]["configs"].items():
        for step, cmd in cmds.items():
            print(f"  {name} {step}: {quote_cmd(cmd)}")
    threads = args.render_threads or available_cores()
    results = execute_run(plan, replayed, threads, args.tool_timeout)
    differ = False
    for r in results:
        f = r["final"]
        shown = ", ".join(f"{k} {fmt(v)}" for k, v in f.items() if v is not None)
        print(f"  {r['config']}: {r['status']}{' (' + r['reason'] + ')' if r['reason'] else ''}; {shown}")
        original = os.path.join(run["dir"], r["config"], "result.json")
        if os.path.exists(original):
            same = deterministic_part(read_json(original)) == deterministic_part(r)
            differ |= not same
            print(f"  {r['config']}: {'identical to' if same else 'DIFFERENT from'} the campaign's result "
                  f"({display_path(original)})")
    return 3 if differ else 0


def campaign_state(scheduler, start_wall, start_mono, load_start, extra):
    state = {"scheduler": scheduler, "started_utc": start_wall,
             "wall_s": round(time.monotonic() - start_mono, 2), "load_average_start": load_start,
             "load_average_end": round(os.getloadavg()[0], 2),
             "cores": available_cores(), "host": socket.gethostname()}
    state.update(extra)
    return state


def mode_campaign(args):
    if args.runs < 1:
        die("--runs must be at least 1", 2)
    if args.size < 16:
        die("--size must be at least 16 px", 2)
    if not args.name:
        args.name = f"{args.sequence}_{args.size}px_{args.duration:g}s_{args.runs}runs_seed{args.seed}"
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", args.name):
        die(f"--name '{args.name}': letters, digits, '_', '.', '-' only", 2)
    out_dir = os.path.abspath(args.output or os.path.join(ROOT, "output", "campaigns", args.name))
    bin_dir = os.path.abspath(args.bin or os.path.join(
        os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build")), "devel", "lib", "planetary_vo"))
    os.makedirs(out_dir, exist_ok=True)
    plan = build_plan(args, out_dir, bin_dir)
    plan_path = os.path.join(out_dir, "runs.json")
    if os.path.exists(plan_path):
        old = load_plan(plan_path)
        if not same_runs(old, plan):
            print(f"vo_campaign: {display_path(plan_path)} described other runs; it is replaced (renders "
                  f"with other parameters are redone, lunar_render's cache skips identical ones)")
    write_json(plan_path, plan)
    # Results of an earlier execution must not stand in for a run that fails to write its own this time.
    for run in plan["runs"]:
        for path in result_paths(plan, run):
            if os.path.exists(path):
                os.remove(path)
    for warning in plan["not_applied"]:
        print(f"vo_campaign: WARNING not applied: {warning}", file=sys.stderr)

    cores = available_cores()
    start_wall, start_mono, load_start = now_utc(), time.monotonic(), round(os.getloadavg()[0], 2)
    print(f"vo_campaign: {args.runs} runs of {args.sequence} at {args.size} px, {args.duration:g} s, "
          f"configurations {', '.join(c['name'] for c in plan['configs'])}; plan {display_path(plan_path)}",
          flush=True)
    missing = []
    if args.scheduler == "local":
        jobs = args.jobs or cores
        concurrency = min(jobs, args.runs)
        threads = args.render_threads or max(1, cores // concurrency)
        print(f"vo_campaign: local, {concurrency} runs at once, {threads} render thread(s) each ({cores} "
              f"cores, load average {load_start})", flush=True)
        missing = execute_local(plan, plan_path, concurrency, threads, args.tool_timeout, args.delete_images)
        extra = {"concurrency": concurrency, "render_threads": threads}
    else:
        job_id, missing = execute_slurm(plan, plan_path, args)
        extra = {"slurm_job_id": job_id, "slurm_conf": os.environ.get("SLURM_CONF"),
                 "concurrency": "Slurm", "render_threads": args.cpus_per_task}
    state = campaign_state(args.scheduler, start_wall, start_mono, load_start, extra)
    write_json(os.path.join(out_dir, "campaign_state.json"), state)
    summary = write_report(plan, out_dir, state)
    print_summary(plan, summary, out_dir)
    if args.write_docs:
        write_docs(out_dir, os.path.abspath(args.write_docs))
    absent = sum(cs["counts"]["missing"] for cs in summary["configs"].values())
    if missing or absent:
        print(f"vo_campaign: {absent} result(s) missing (runs {', '.join(missing) or '?'}): see the task "
              f"logs", file=sys.stderr)
        return 1
    return 0


def mode_gather(args):
    if not args.output and not args.plan:
        die("--gather needs --output CAMPAIGN_FOLDER", 2)
    out_dir = os.path.abspath(args.output or os.path.dirname(os.path.abspath(args.plan)))
    plan = load_plan(os.path.join(out_dir, "runs.json"))
    state_path = os.path.join(out_dir, "campaign_state.json")
    state = read_json(state_path) if os.path.exists(state_path) else None
    summary = write_report(plan, out_dir, state)
    print_summary(plan, summary, out_dir)
    if args.write_docs:
        write_docs(out_dir, os.path.abspath(args.write_docs))
    absent = sum(cs["counts"]["missing"] for cs in summary["configs"].values())
    if absent:
        print(f"vo_campaign: {absent} result(s) missing", file=sys.stderr)
        return 1
    return 0


def parse_args(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_argument_group("campaign")
    g.add_argument("--sequence", default="approach_down", help="Lunar sequence (lunar_render --list)")
    g.add_argument("--runs", type=int, default=50, help="number of dispersed runs (default 50)")
    g.add_argument("--size", type=int, default=256, help="image side in pixels (default 256)")
    g.add_argument("--duration", type=float, default=20.0,
                   help="render the first S seconds (0 = all; default 20)")
    g.add_argument("--rate", type=float, default=0.0, help="camera rate in Hz (default: lunar_render's)")
    g.add_argument("--configs", default="default",
                   help="comma-separated VO configurations: names in config/ or YAML paths "
                        "(default: default)")
    g.add_argument("--sensors", default="flight",
                   help="lunar_render sensor preset, flight or ideal (default flight)")
    g.add_argument("--imu-grade", default=None, help="lunar_render --imu-grade for every run")
    g.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="lunar_render --set for every run (repeatable)")
    g.add_argument("--seed", type=int, default=1,
                   help="campaign seed: every dispersion is drawn from it (default 1)")
    g.add_argument("--name", default=None, help="campaign name (default SEQUENCE_SIZEpx_DURs_Nruns_seedS)")
    g.add_argument("--output", default=None,
                   help="campaign folder (default output/campaigns/NAME); with --replay the replay's folder")
    g.add_argument("--bin", default=None,
                   help="folder of lunar_render, vo_run, vo_eval (default $PLANETARY_VO_BUILD/devel/lib/"
                        "planetary_vo, $PLANETARY_VO_BUILD defaulting to build/)")
    g.add_argument("--write-docs", default=None, metavar="DIR",
                   help="copy summary.md, summary.json, plots/ to DIR")
    d = ap.add_argument_group("dispersions (docs/campaigns.md)")
    d.add_argument("--terrain-seed", type=int, default=None,
                   help="fix the terrain seed (default: uniform per run)")
    d.add_argument("--sensor-seed", type=int, default=None,
                   help="fix the sensor seed (default: uniform per run)")
    d.add_argument("--dems", default=DEFAULTS["dems"],
                   help=f"comma-separated DEMs drawn uniformly (default {DEFAULTS['dems']})")
    d.add_argument("--placement-ranks", default=DEFAULTS["placement_ranks"],
                   help=f"DEM placement rank LO-HI, uniform (default {DEFAULTS['placement_ranks']})")
    d.add_argument("--sun-elevation", default=DEFAULTS["sun_elevation"],
                   help=f"Sun elevation LO,HI deg uniform, or one value "
                        f"(default {DEFAULTS['sun_elevation']})")
    d.add_argument("--sun-azimuth", default=DEFAULTS["sun_azimuth"],
                   help=f"Sun azimuth LO,HI deg uniform, or one value (default {DEFAULTS['sun_azimuth']})")
    d.add_argument("--init-position-sigma-m", type=float, default=DEFAULTS["init_position_sigma_m"],
                   help=f"initial position error sigma per axis "
                        f"(default {DEFAULTS['init_position_sigma_m']} m)")
    d.add_argument("--init-attitude-sigma-deg", type=float, default=DEFAULTS["init_attitude_sigma_deg"],
                   help=f"initial attitude error sigma per axis "
                        f"(default {DEFAULTS['init_attitude_sigma_deg']} deg)")
    d.add_argument("--init-scale-sigma-percent", type=float, default=DEFAULTS["init_scale_sigma_percent"],
                   help=f"initial scale error sigma (default {DEFAULTS['init_scale_sigma_percent']} %%)")
    d.add_argument("--first-scale-window", type=float, default=DEFAULTS["first_scale_window_s"],
                   help="vo_eval first-pose alignment: scale from the first S seconds "
                        f"(default {DEFAULTS['first_scale_window_s']} s)")
    x = ap.add_argument_group("execution")
    x.add_argument("--scheduler", choices=("local", "slurm"), default="local")
    x.add_argument("--jobs", type=int, default=0, help="local: runs at once (default: all cores)")
    x.add_argument("--render-threads", type=int, default=0,
                   help="lunar_render --threads per run (default: cores / runs at once; Slurm: "
                        "cpus-per-task)")
    x.add_argument("--tool-timeout", type=float, default=7200.0,
                   help="seconds after which one tool call is killed (0 = none; default 7200)")
    x.add_argument("--delete-images", action="store_true",
                   help="delete each run's images after its VO runs (saves disk; a re-run renders again)")
    x.add_argument("--slurm-args", default="",
                   help="extra sbatch arguments, e.g. \"--partition=short --time=00:30:00 --account=gnc\"")
    x.add_argument("--cpus-per-task", type=int, default=1, help="Slurm: CPUs per array task (default 1)")
    x.add_argument("--array-limit", type=int, default=0, help="Slurm: at most this many tasks at once (%%N)")
    x.add_argument("--poll-interval", type=float, default=2.0, help="Slurm: seconds between squeue polls")
    x.add_argument("--slurm-timeout", type=float, default=0.0,
                   help="Slurm: cancel the array after this many seconds (0 = wait forever)")
    m = ap.add_argument_group("other modes")
    m.add_argument("--replay", default=None, metavar="RUN_ID",
                   help="run one run of --plan alone into --output")
    m.add_argument("--plan", default=None, help="the campaign's runs.json (for --replay and --run-one)")
    m.add_argument("--gather", action="store_true", help="only gather the campaign folder --output")
    m.add_argument("--run-one", type=int, default=None, metavar="K",
                   help="execute run K of --plan (Slurm task)")
    return ap.parse_args(argv)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if args.run_one is not None:
        if not args.plan:
            die("--run-one needs --plan", 2)
        return mode_run_one(args)
    if args.replay is not None:
        return mode_replay(args)
    if args.gather:
        return mode_gather(args)
    return mode_campaign(args)


if __name__ == "__main__":
    sys.exit(main())
