#!/usr/bin/python3
"""The VO benchmark: every Lunar sequence with flight-like and ideal sensors, held-out terrain, the KITTI clip.

Each row is a dataset under stated conditions (sequence, image size, sensor preset, Sun, terrain seed, DEM and
placement, sensor seed). The script renders it (lunar_render caches unchanged renders), runs vo_run with each
configuration, scores the trajectory with vo_eval and prints one table:

  Sim(3) alignment   ATE (% of the path), attitude drift (error of the attitude change since the first pose),
                     one-frame relative translation error, scale error over time (RMS, % of the global scale)
  first-pose         the navigation is handed its initial state (pose and, for a VO without metric scale, the
  alignment          scale of the velocity over the first FIRST_SCALE_WINDOW_S seconds): error at the end (the
                     low gate) in m and in % of the distance travelled, velocity error RMS, tilt error at the end
  ATE unaligned,     metric rows only: the ATE RMSE in m without any alignment, and the mean NEES of position, of
  NEES pos / att /   attitude (rows with a pose covariance: imu, fused, altimeter) and of the velocity (rows
  vel                whose velocity comes with a covariance: altimeter, the motion filter's); 3 dof each, a
                     consistent covariance gives 3; "-" for the monocular VO (no metric scale)
  posed              frames whose pose was estimated (TRACKING or RECOVERED) / processed frames
  mark               correct: Sim(3) ATE <= 1 % and attitude drift <= 0.5 deg; partial: ATE <= 5 %; failed: worse,
                     or fewer than 90 % of the frames posed (lost)

Groups of rows (--groups, default all):
  flight     the six sequences at 1024x1024 with the flight sensors (the README headline)
  ideal      the six sequences at 1024x1024 with the ideal sensors (what the defaults were tuned on)
  ideal512   the six at 512x512, ideal sensors: the images of ../shared/docs/peer-results.md, peers beside us
  heldout    flight sensors on terrain, seeds and Sun angles the defaults never saw
  kitti      the real KITTI 98 deg turn clip (../shared/data/kitti_clip_turn)
  altimeter  vision + laser altimeter (config/lunar_altimeter.yaml) on the six flight-sensor datasets: metric, so
             vo_run is handed the first true pose only (--initial-state-from-groundtruth) and the end, velocity
             and tilt columns are scored without any alignment (vo_eval --align none); the velocity column is
             the motion filter's velocity (vo_run --output-velocity, what nav/odometry gives guidance)
  imu        camera + IMU (config/lunar_imu.yaml), the same way, handed the first true pose and velocity; the
             velocity column is the estimator's own velocity (vo_run --output-velocity)
  fused      camera + IMU + altimeter (config/lunar_fused.yaml), the same way

Usage (after `bash scripts/demo.sh` has built the tools):
  /usr/bin/python3 scripts/vo_benchmark.py [--groups flight,ideal,...] [--sequences a,b] [--configs default,...]
                                            [--duration S] [--write-docs] [--output DIR] [--starts N]

--starts N also runs each monocular row from input images 1..N-1 (vo_run --first-frame; start 0 is the row
itself) and prints the median Sim(3) ATE over the N starts, every frame and keyframes, next to DSO: a single
run's ATE moves by up to 3x with the image it starts at (docs/visual_core.md, step 6).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LUNAR_SEQUENCES = ["main_brake_down", "main_brake_30deg", "main_brake_pitch",
                   "approach_down", "approach_30deg", "approach_nozzle"]
CORRECT_ATE_PERCENT = 1.0
CORRECT_ROTATION_DEG = 0.5
PARTIAL_ATE_PERCENT = 5.0
MIN_COVERAGE = 0.9
FIRST_SCALE_WINDOW_S = 2.0
# The conditions the VO defaults were tuned on (sessions 1-2: ideal sensors, these values, the six sequences).
TUNED = {"dem": "apollo15_gld100", "seed": 1, "placement_rank": 0, "sun_elevation": 12.0, "sun_azimuth": 250.0}


def lunar_row(group, sequence, size, sensors, **kw):
    row = {"group": group, "sequence": sequence, "size": size, "sensors": sensors, "sensor_seed": 1}
    row.update(TUNED)
    row.update(kw)
    return row


def default_rows():
    rows = []
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("flight", s, 1024, "flight"))
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("ideal", s, 1024, "ideal"))
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("ideal512", s, 512, "ideal"))
    # Held out: other DEM, terrain seeds and placements, low and high Sun, other sensor seeds. (At Sun 7/100 deg the
    # whole Apollo 17 placement lies in the East Massif's shadow: the images are black, see docs/results.md.)
    rows.append(lunar_row("heldout", "approach_down", 1024, "flight", dem="apollo17_gld100", seed=7,
                          sun_elevation=7.0, sun_azimuth=280.0, sensor_seed=7))
    rows.append(lunar_row("heldout", "approach_nozzle", 1024, "flight", seed=13, placement_rank=2,
                          sun_elevation=45.0, sun_azimuth=30.0, sensor_seed=13))
    rows.append({"group": "kitti", "sequence": "kitti_clip_turn", "size": None, "sensors": "real camera"})
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("altimeter", s, 1024, "flight", configs=["lunar_altimeter"], metric=True,
                              velocity=True))
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("imu", s, 1024, "flight", configs=["lunar_imu"], metric=True, velocity=True))
    for s in LUNAR_SEQUENCES:
        rows.append(lunar_row("fused", s, 1024, "flight", configs=["lunar_fused"], metric=True, velocity=True))
    return rows


def run(cmd, log_path):
    """Runs cmd, sending its output to log_path; returns (exit code, seconds)."""
    start = time.monotonic()
    with open(log_path, "w") as log:
        log.write("$ " + " ".join(cmd) + "\n")
        log.flush()
        rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    return rc, time.monotonic() - start


def vo_run_is_current(run_log, traj, inputs):
    """True when vo_run already ran to its end on these inputs: its log holds the final "states:" summary, no
    failed exit, and is newer than every input (the dataset's render stamp, the configuration, the vo_run
    binary)."""
    if not (os.path.exists(run_log) and os.path.exists(traj)):
        return False
    with open(run_log) as f:
        text = f.read()
    if "\nstates: " not in text or re.search(r"vo_benchmark: vo_run exit [1-9-]", text):
        return False
    newest_input = max(os.path.getmtime(p) for p in inputs if os.path.exists(p))
    return os.path.getmtime(run_log) > newest_input


def run_vo(cmd, run_log, traj, inputs, rerun):
    """Runs vo_run unless an identical run is on disk (same inputs, see vo_run_is_current); returns
    (exit code, reused)."""
    if not rerun and vo_run_is_current(run_log, traj, inputs):
        return 0, True
    rc, _ = run(cmd, run_log)
    with open(run_log, "a") as log:
        log.write(f"\nvo_benchmark: vo_run exit {rc}\n")
    return rc, False


def count_lines(path):
    if not os.path.exists(path):
        return 0
    with open(path) as f:
        return sum(1 for line in f if line.strip() and not line.startswith("#"))


# The stages vo_run times per frame (FrameResult::times, frame_result.h), in its order; pyramid, klt, refine and
# detect are parts of tracking. optimiser is per adjustment, not per frame: the bundle adjustment's own solve.
STAGES = ["tracking", "pyramid", "klt", "refine", "detect", "motion", "mapping", "ba", "pose", "total", "optimiser"]


def parse_vo_run_log(path):
    """Coverage (estimated frames only) and the per-frame time of each stage (median, p99) and of the whole
    process() call."""
    found = {}
    with open(path) as f:
        for line in f:
            m = re.search(r"(\d+) processed frames", line)
            if m:
                found["processed"] = int(m.group(1))
            m = re.search(r"states: initialising (\d+), tracking (\d+), lost (\d+), recovered (\d+)", line)
            if m:
                found["tracking"], found["lost"], found["recovered"] = (int(m.group(2)), int(m.group(3)),
                                                                        int(m.group(4)))
            m = re.match(r"\s*(%s)\s+([0-9.]+)\s+([0-9.]+)\s*(\(\d+ adjustments\))?\s*$" % "|".join(STAGES), line)
            if m:
                found.setdefault("stage_ms", {})[m.group(1)] = (float(m.group(2)), float(m.group(3)))
                if m.group(1) == "total":
                    found["track_median_ms"], found["track_p99_ms"] = float(m.group(2)), float(m.group(3))
    if found.get("processed"):
        found["coverage"] = (found.get("tracking", 0) + found.get("recovered", 0)) / found["processed"]
    return found


def mark(ate_percent, drift_deg, coverage):
    if ate_percent is None:
        return "failed"
    if coverage < MIN_COVERAGE:
        return "failed (lost)"
    if ate_percent <= CORRECT_ATE_PERCENT and drift_deg <= CORRECT_ROTATION_DEG:
        return "correct"
    if ate_percent <= PARTIAL_ATE_PERCENT:
        return "partial"
    return "failed"


def dataset_name(row, duration):
    name = f"{row['sequence']}_{row['size']}px_{row['sensors']}"
    if row["dem"] != TUNED["dem"]:
        name += "_" + row["dem"].split("_")[0]
    if row["seed"] != 1:
        name += f"_seed{row['seed']}"
    if row["placement_rank"]:
        name += f"_place{row['placement_rank']}"
    if (row["sun_elevation"], row["sun_azimuth"]) != (TUNED["sun_elevation"], TUNED["sun_azimuth"]):
        name += f"_sun{row['sun_elevation']:g}az{row['sun_azimuth']:g}"
    if row["sensors"] != "ideal" and row["sensor_seed"] != 1:
        name += f"_sseed{row['sensor_seed']}"
    if duration > 0:
        name += f"_{duration:g}s"
    return name


def render_command(row, bin_dir, dataset, duration):
    """The lunar_render call that makes a Lunar row's dataset (cached by lunar_render when unchanged)."""
    cmd = [os.path.join(bin_dir, "lunar_render"), "--sequence", row["sequence"], "--output", dataset,
           "--width", str(row["size"]), "--height", str(row["size"]), "--sensors", row["sensors"],
           "--seed", str(row["seed"]), "--dem", row["dem"], "--placement-rank", str(row["placement_rank"]),
           "--sun-elevation", str(row["sun_elevation"]), "--sun-azimuth", str(row["sun_azimuth"]),
           "--sensor-seed", str(row["sensor_seed"]), "--no-progress"]
    if duration > 0:
        cmd += ["--duration", str(duration)]
    return cmd


def eval_frame_args(sequence):
    """vo_eval's frame options for a dataset: KITTI's camera frame has y down (the Lunar datasets are z up)."""
    return ["--up-axis", "-y", "--axes", "xyz"] if sequence == "kitti_clip_turn" else []


def row_key(row):
    return json.dumps({k: row.get(k) for k in ("group", "sequence", "size", "sensors", "dem", "seed",
                                                 "placement_rank", "sun_elevation", "sun_azimuth", "sensor_seed",
                                                 "config")}, sort_keys=True)


def conditions(row):
    if row["sequence"] == "kitti_clip_turn":
        return "1241x376", "real camera", "-", "KITTI 06 (real)", "-"
    terrain = f"{row['dem'].split('_')[0]} #{row['placement_rank']}, seed {row['seed']}"
    sensor_seed = str(row["sensor_seed"]) if row["sensors"] != "ideal" else "-"
    return (f"{row['size']}x{row['size']}", row["sensors"], f"{row['sun_elevation']:g}/{row['sun_azimuth']:g}",
            terrain, sensor_seed)


def held_out(row):
    """Whether the row's conditions differ from what the defaults were tuned on."""
    if row["sequence"] == "kitti_clip_turn":
        return "tuned on"
    differs = [k for k in TUNED if row[k] != TUNED[k]]
    if differs:
        return "held out"
    return "sensors only" if row["sensors"] != "ideal" else "tuned on"


def eval_metrics(sim3, first):
    """The benchmark's numbers from vo_eval's JSON (docs/evaluation.md)."""
    m = {}
    if sim3:
        m["ate_percent"] = sim3["ate_rmse_percent_of_path"]
        m["drift_deg"] = sim3["attitude_drift_deg"]["rmse"]
        for r in sim3.get("rpe", []):
            if r.get("delta_unit") == "frames" and r.get("delta") == 1:
                m["rpe1_percent"] = r["translation_percent"]["median"]
            if r.get("delta_unit") == "m" and abs(r.get("path_fraction", 0) - 0.1) < 1e-6 and r.get("num_pairs"):
                m["rpe_dist_percent"] = r["translation_percent"]["rmse"]
                m["rpe_dist_m"] = r["delta"]
        if sim3.get("scale_error_percent"):
            m["scale_err_percent"] = sim3["scale_error_percent"]["rmse"]
    if first:
        fin = first.get("final", {})
        m["end_error_m"] = fin.get("position_error_m")
        m["end_error_percent"] = fin.get("position_error_percent_of_distance")
        m["end_tilt_deg"] = fin.get("tilt_error_deg")
        if first.get("velocity_error_mps"):
            m["velocity_rms_mps"] = first["velocity_error_mps"]["rmse"]
        if first.get("alignment", {}).get("mode") == "none":
            m["abs_ate_m"] = first.get("ate_m", {}).get("rmse")
        nees = first.get("nees") or {}
        if nees.get("position"):
            m["nees_position"] = nees["position"]["mean"]
        if nees.get("attitude"):
            m["nees_attitude"] = nees["attitude"]["mean"]
        if nees.get("velocity"):
            m["nees_velocity"] = nees["velocity"]["mean"]
    return m


def eval_sim3(bin_dir, gt, est, sequence, json_path, log_path, extra=()):
    """vo_eval --align sim3 of the trajectory `est` (at least 3 poses) into json_path; its JSON, or None when the
    trajectory is too short or vo_eval fails."""
    if count_lines(est) < 3:
        return None
    cmd = [os.path.join(bin_dir, "vo_eval"), "--gt", gt, "--est", est] + eval_frame_args(sequence) + \
        ["--align", "sim3", "--json", json_path] + list(extra)
    if run(cmd, log_path)[0] != 0:
        return None
    with open(json_path) as f:
        return json.load(f)


def median(values):
    v = sorted(values)
    n = len(v)
    return None if n == 0 else (v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2]))


def score_starts(bin_dir, dataset, gt, config_path, out, sequence, starts, rerun, stamp):
    """The run of a row again from input images 1 .. starts-1 (vo_run --first-frame; start 0 is the row's own
    run), each in out/startN/, scored like it (Sim(3), every frame and the keyframes after optimisation).
    Returns {"ate_percent": [...], "keyframes_ate_percent": [...], "coverage": [...]} over starts 1..N-1 (a
    start that fails or is lost has None for its ATE). One run's ATE moves by up to 3x with the image it starts
    at (docs/visual_core.md, step 6): the median over a few starts is the figure to compare."""
    scores = {"ate_percent": [], "keyframes_ate_percent": [], "coverage": []}
    vo_run = os.path.join(bin_dir, "vo_run")
    for n in range(1, starts):
        d = os.path.join(out, f"start{n}")
        os.makedirs(d, exist_ok=True)
        traj, keyframes = os.path.join(d, "trajectory.txt"), os.path.join(d, "keyframes.txt")
        log = os.path.join(d, "vo_run.log")
        rc, _ = run_vo([vo_run, "--dataset", dataset, "--config", config_path, "--first-frame", str(n),
                        "--output", traj, "--output-keyframes", keyframes], log, traj, [stamp, config_path, vo_run],
                       rerun)
        coverage = parse_vo_run_log(log).get("coverage", 0.0) if rc == 0 else 0.0
        ates = []
        for est, name in ((traj, "eval_sim3"), (keyframes, "eval_keyframes_sim3")):
            scored = eval_sim3(bin_dir, gt, est, sequence, os.path.join(d, name + ".json"),
                               os.path.join(d, name + ".log")) if rc == 0 else None
            ates.append(scored["ate_rmse_percent_of_path"] if scored else None)
        lost = coverage < MIN_COVERAGE
        scores["ate_percent"].append(None if lost else ates[0])
        scores["keyframes_ate_percent"].append(None if lost else ates[1])
        scores["coverage"].append(coverage)
    return scores


def fmt_starts(r, key):
    """'median (min-max)' of a row's ATE over its starts (start 0 and --starts' others); a lost start counts as
    worst; '-' without starts."""
    first = r.get(key) if r.get("coverage", 0.0) >= MIN_COVERAGE else None
    others = r.get("starts", {}).get(key)
    if others is None:
        return "-"
    values = [first] + others
    valid = sorted(v for v in values if v is not None)
    lost = len(values) - len(valid)
    if not valid:
        return "lost"
    ordered = valid + [float("inf")] * lost
    m = median(ordered)
    text = "lost" if m == float("inf") else f"{m:.4f}"
    text += f" ({valid[0]:.4f}-{valid[-1]:.4f}" + (f", {lost} lost" if lost else "") + ")"
    return text


def peers_table():
    """Sim(3) ATE % of DSO, SVO 1 and ORB-SLAM3 on the 512x512 ideal renders, from peer-results.md."""
    path = os.path.join(ROOT, "..", "shared", "docs", "peer-results.md")
    peers = {}
    if not os.path.exists(path):
        return peers
    with open(path) as f:
        text = f.read()
    start = text.find("## Our own six Lunar sequences")
    if start < 0:
        return peers
    for line in text[start:].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 5 and cells[0] in LUNAR_SEQUENCES:
            peers[cells[0]] = {"DSO": cells[1], "SVO 1": cells[2], "ORB-SLAM3": cells[3], "ours then": cells[4]}
    return peers


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--output", default=os.path.join(ROOT, "output", "benchmark"))
    ap.add_argument("--data", default=os.environ.get("PLANETARY_VO_DATA", os.path.join(ROOT, "..", "shared", "data")))
    ap.add_argument("--groups", default="flight,ideal,ideal512,heldout,kitti,altimeter,imu,fused")
    ap.add_argument("--sequences", default="", help="comma-separated sequence names to keep (default: all)")
    ap.add_argument("--duration", type=float, default=0.0, help="render only the first S seconds (0 = all)")
    ap.add_argument("--configs", default="default", help="VO configurations (config/NAME.yaml)")
    ap.add_argument("--thesis-configs", action="store_true",
                    help="also run thesis_F, thesis_E, thesis_H on the ideal 1024 rows (thesis Table 4.8)")
    ap.add_argument("--write-docs", action="store_true", help="write docs/results.md and its plots")
    ap.add_argument("--starts", type=int, default=1,
                    help="also run each monocular row from input images 1..N-1 (vo_run --first-frame) and give the "
                         "median Sim(3) ATE over the N starts next to the peers (one run moves by up to 3x with "
                         "where it starts)")
    ap.add_argument("--rerun-vo", action="store_true",
                    help="run vo_run even where its trajectory is current (same dataset, configuration and "
                         "binary); by default such a run is reused and only scored again")
    args = ap.parse_args()
    if args.starts < 1:
        sys.exit(f"vo_benchmark: --starts needs at least 1, got {args.starts}")

    bin_dir = os.path.join(args.build, "devel", "lib", "planetary_vo")
    for tool in ("lunar_render", "vo_run", "vo_eval"):
        if not os.path.exists(os.path.join(bin_dir, tool)):
            sys.exit(f"vo_benchmark: {tool} not found in {bin_dir}: build first (bash scripts/demo.sh builds)")
    os.makedirs(args.output, exist_ok=True)
    groups = args.groups.split(",")
    keep = set(args.sequences.split(",")) if args.sequences else None
    plan = [r for r in default_rows() if r["group"] in groups and (keep is None or r["sequence"] in keep)]
    started = time.monotonic()

    results = []
    for row in plan:
        if row["sequence"] == "kitti_clip_turn":
            dataset = os.path.join(args.data, "kitti_clip_turn")
            gt = os.path.join(dataset, "poses.txt")
            run_name = "kitti_clip_turn"
        else:
            name = dataset_name(row, args.duration)
            dataset = os.path.join(args.output, "sequences", name)
            gt = dataset
            run_name = name
            cmd = render_command(row, bin_dir, dataset, args.duration)
            os.makedirs(os.path.dirname(dataset), exist_ok=True)
            rc, secs = run(cmd, dataset + ".render.log")
            if rc != 0:
                sys.exit(f"vo_benchmark: rendering {name} failed, see {dataset}.render.log")
            print(f"[{name}] dataset ready ({secs:.0f} s)", flush=True)
        configs = row.get("configs", args.configs.split(","))
        if args.thesis_configs and row["group"] == "ideal":
            configs += ["thesis_F", "thesis_E", "thesis_H"]
        for config in configs:
            r = dict(row)
            r["config"] = config
            out = os.path.join(args.output, "runs", run_name, config)
            os.makedirs(out, exist_ok=True)
            traj = os.path.join(out, "trajectory.txt")
            keyframes = os.path.join(out, "keyframes.txt")
            run_log = os.path.join(out, "vo_run.log")
            config_path = os.path.join(ROOT, "config", config + ".yaml")
            stamp = os.path.join(dataset, "render_stamp.txt") if row["sequence"] != "kitti_clip_turn" else gt
            handover = ["--initial-state-from-groundtruth"] if row.get("metric") else []
            velocity = os.path.join(out, "velocity.txt")
            covariance = os.path.join(out, "covariance.txt")
            if row.get("velocity"):
                handover += ["--output-velocity", velocity, "--output-covariance", covariance]
            rc, reused = run_vo([os.path.join(bin_dir, "vo_run"), "--dataset", dataset, "--config", config_path,
                                 "--output", traj, "--output-keyframes", keyframes] + handover, run_log, traj,
                                [stamp, config_path, os.path.join(bin_dir, "vo_run")], args.rerun_vo)
            r.update({"coverage": 0.0, "vo_run_rc": rc, "vo_run_reused": reused,
                      "run_dir": os.path.relpath(out, args.output)})
            r.update(parse_vo_run_log(run_log))
            sim3 = first = None
            if rc == 0 and count_lines(traj) >= 3:
                common = [os.path.join(bin_dir, "vo_eval"), "--gt", gt, "--est", traj]
                common += eval_frame_args(row["sequence"])
                first_json = os.path.join(out, "eval_first.json")
                sim3 = eval_sim3(bin_dir, gt, traj, row["sequence"], os.path.join(out, "eval_sim3.json"),
                                 os.path.join(out, "vo_eval_sim3.log"),
                                 ["--plot", os.path.join(out, "plots")] if args.write_docs else [])
                # The keyframes with their last estimate (not causal), scored like DSO's result.txt. A run reused
                # from before --output-keyframes existed has no such file.
                kf = eval_sim3(bin_dir, gt, keyframes, row["sequence"], os.path.join(out, "eval_keyframes_sim3.json"),
                               os.path.join(out, "vo_eval_keyframes_sim3.log"))
                if kf:
                    r["keyframes_ate_percent"] = kf["ate_rmse_percent_of_path"]
                    r["keyframes_posed"] = count_lines(keyframes)
                # A metric estimate handed its first pose is scored as guidance reads it: no alignment at all.
                align = ["--align", "none"] if row.get("metric") else \
                    ["--align", "first", "--first-scale-window", str(FIRST_SCALE_WINDOW_S)]
                cmd = common + align + ["--json", first_json]
                if row.get("velocity"):
                    cmd += ["--est-velocity", velocity, "--est-cov", covariance]
                if run(cmd, os.path.join(out, "vo_eval_first.log"))[0] == 0:
                    with open(first_json) as f:
                        first = json.load(f)
            r.update(eval_metrics(sim3, first))
            r["mark"] = mark(r.get("ate_percent"), r.get("drift_deg") or 0.0, r["coverage"])
            if args.starts > 1 and not row.get("metric"):
                r["starts"] = score_starts(bin_dir, dataset, gt, config_path, out, row["sequence"], args.starts,
                                           args.rerun_vo, stamp)
            results.append(r)
            print(format_row(r), flush=True)

    # Rows not run this time are kept from earlier runs into the same --output folder, so that a long benchmark
    # can be run a few groups at a time.
    results_path = os.path.join(args.output, "results.json")
    run_now = {row_key(r) for r in results}
    if os.path.exists(results_path):
        with open(results_path) as f:
            results += [r for r in json.load(f) if "group" in r and row_key(r) not in run_now]
    order = ["flight", "ideal", "ideal512", "heldout", "kitti", "altimeter", "imu", "fused"]
    results.sort(key=lambda r: (order.index(r["group"]) if r["group"] in order else len(order),
                                LUNAR_SEQUENCES.index(r["sequence"]) if r["sequence"] in LUNAR_SEQUENCES else 9))
    tables = format_tables(results)
    print()
    print(tables)
    print(f"\nvo_benchmark: {len(plan)} rows in {time.monotonic() - started:.0f} s wall")
    with open(results_path, "w") as f:
        json.dump(results, f, indent=1)
    if args.write_docs:
        missing = [g for g in order if not any(r["group"] == g for r in results)]
        if missing:
            print("vo_benchmark: warning: the table written to docs/results.md has no rows for " +
                  ", ".join(missing) + " (never run into " + args.output + "; run them with --groups)",
                  flush=True)
        write_docs(tables, results, args)


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


HEADER = ("| sequence | image | sensors | Sun el/az deg | terrain (DEM #placement, seed) | sensor seed | "
          "defaults | config | Sim3 ATE % | attitude drift deg | 1-frame RPE % | RPE over 10 % of path, % | "
          "scale err RMS % | "
          "end err m (% dist) | velocity err RMS m/s | end tilt deg | ATE unaligned, NEES pos / att / vel | posed | mark | "
          "ms/frame median / p99 |")


def se3_nees(r):
    """The metric rows' ATE without any alignment and the mean NEES of position / attitude / velocity (3 dof
    each: a consistent covariance gives 3)."""
    if not r.get("metric"):
        return "- (no metric scale)"
    ate = "-" if r.get("abs_ate_m") is None else f"{r['abs_ate_m']:.2f} m"
    if r.get("nees_position") is None and r.get("nees_velocity") is None:
        return f"{ate}, - (no covariance)"
    return (f"{ate}, {fmt(r.get('nees_position'), '.2f')} / {fmt(r.get('nees_attitude'), '.2f')} / "
            f"{fmt(r.get('nees_velocity'), '.2f')}")


def format_row(r):
    image, sensors, sun, terrain, sseed = conditions(r)
    end = "-" if r.get("end_error_m") is None else \
        f"{r['end_error_m']:.2f} ({fmt(r.get('end_error_percent'), '.3f')} %)"
    return (f"| {r['sequence']} | {image} | {sensors} | {sun} | {terrain} | {sseed} | {held_out(r)} | "
            f"{r['config']} | {fmt(r.get('ate_percent'), '.3f')} | {fmt(r.get('drift_deg'), '.3f')} | "
            f"{fmt(r.get('rpe1_percent'), '.2f')} | {fmt(r.get('rpe_dist_percent'), '.2f')} | "
            f"{fmt(r.get('scale_err_percent'), '.2f')} | {end} | "
            f"{fmt(r.get('velocity_rms_mps'), '.2f')} | {fmt(r.get('end_tilt_deg'), '.3f')} | "
            f"{se3_nees(r)} | "
            f"{r.get('coverage', 0) * 100:.0f} % | {r['mark']} | "
            f"{fmt(r.get('track_median_ms'), '.1f')} / {fmt(r.get('track_p99_ms'), '.1f')} |")


def format_tables(results):
    sep = "|" + "---|" * HEADER.count(" |")
    lines = [HEADER, sep] + [format_row(r) for r in results]
    timed = [r for r in results if r.get("stage_ms")]
    if timed:
        lines += ["", "Time per processed frame by stage, median / p99 in ms (vo_run, FrameResult::times: tracking = "
                  "image pyramid, KLT, anchor refinement, replenishment detection, undistortion, of which pyramid, klt "
                  "(forward and backward LK), refine (anchor refinement) and detect are parts; motion = two-view or PnP + "
                  "motion-only refinement; mapping = keyframe insertion, triangulation, culling; ba = synchronous "
                  "bundle adjustment, or handing the window to the optimiser thread and applying its result, "
                  "including any wait for it; pose = image in, pose out: from entering process() until the pose is "
                  "known, before the keyframe decision and mapping; total = the whole Pipeline::process() call; "
                  "optimiser = per adjustment, not per frame: the bundle adjustment's CPU time in its thread, which "
                  "shares the CPU with the tracking; the others are wall clock). "
                  "Wall clock on this "
                  f"machine (nproc {os.cpu_count()}), other jobs not excluded:", "",
                  "| sequence | image | sensors | config | " + " | ".join(STAGES) + " |",
                  "|---|---|---|---|" + "---|" * len(STAGES)]
        for r in timed:
            image, sensors = conditions(r)[:2]
            cells = []
            for stage in STAGES:
                t = r["stage_ms"].get(stage)
                cells.append("-" if t is None else f"{t[0]:.2f} / {t[1]:.2f}")
            lines.append(f"| {r['sequence']} | {image} | {sensors} | {r['config']} | " + " | ".join(cells) + " |")
    peers = peers_table()
    ideal512 = [r for r in results if r["group"] == "ideal512" and r["config"] == "default"]
    # Every configuration that ran several starts (e.g. --configs default,dense_map), each next to DSO.
    with_starts = [r for r in results if r.get("starts")]
    if with_starts:
        lines += ["", "Over several starts (vo_run --first-frame 0..N-1: the same images, the run started at a "
                  "later one; Sim(3) ATE % of the path, median (range); a lost start counts as worst):", "",
                  "| sequence | image | sensors | config | starts | every frame | keyframes after optimisation | "
                  "DSO (peer-results.md) |", "|---|---|---|---|---|---|---|---|"]
        for r in with_starts:
            image, sensors = conditions(r)[:2]
            dso = peers.get(r["sequence"], {}).get("DSO", "-") if r["group"] == "ideal512" else "-"
            lines.append(f"| {r['sequence']} | {image} | {sensors} | {r['config']} | "
                         f"{1 + len(r['starts']['ate_percent'])} | {fmt_starts(r, 'ate_percent')} | "
                         f"{fmt_starts(r, 'keyframes_ate_percent')} | {dso} |")
    if ideal512:
        lines += ["", "Peers on the same 512x512 ideal images (Sim3 ATE % of the path; peers from "
                  "../shared/docs/peer-results.md, measured outside the project; ours measured by this run):", "",
                  "| sequence | DSO | SVO 1 | ORB-SLAM3 mono | planetary_vo (peer-results.md, commit fca964c) | "
                  "planetary_vo now | posed | planetary_vo now, keyframes after optimisation |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in ideal512:
            p = peers.get(r["sequence"], {})
            lines.append(f"| {r['sequence']} | {p.get('DSO', '?')} | {p.get('SVO 1', '?')} | {p.get('ORB-SLAM3', '?')} | "
                         f"{p.get('ours then', '?')} | {fmt(r.get('ate_percent'), '.3f')} % | "
                         f"{r.get('coverage', 0) * 100:.0f} % | {fmt(r.get('keyframes_ate_percent'), '.3f')} % "
                         f"({r.get('keyframes_posed', '-')} keyframes) |")
        lines += ["", "planetary_vo now: every frame's pose as it was output (causal, what guidance reads). Keyframes "
                  "after optimisation: only the keyframes, each with its pose when it left the bundle adjustment's "
                  "window (vo_run --output-keyframes; not causal). DSO writes that kind of trajectory by default "
                  "(result.txt holds the keyframes' final poses, setting_onlyLogKFPoses), ORB-SLAM its "
                  "KeyFrameTrajectory.txt; peer-results.md does not say which poses its peers were scored on."]
    return "\n".join(lines)


def write_docs(tables, results, args):
    docs = os.path.join(ROOT, "docs")
    plots = os.path.join(docs, "results")
    os.makedirs(plots, exist_ok=True)
    lines = ["# VO benchmark results", "",
             "Produced by one command from a clean clone (after `bash scripts/demo.sh` has built the tools):", "",
             "```sh", "/usr/bin/python3 scripts/vo_benchmark.py " + " ".join(sys.argv[1:]), "```", "",
             ("First " + f"{args.duration:g} s of each Lunar sequence." if args.duration else
              "Full Lunar sequences (10 Hz); KITTI clip at its own size."),
             "Every row states its conditions: image size, sensor preset (`flight`: every error model of "
             "docs/sensors/ on; `ideal`: perfect sensors), Sun elevation/azimuth, terrain (DEM, placement rank, "
             "terrain seed) and sensor seed. `defaults` says whether the VO defaults were tuned on these "
             "conditions (`tuned on`: ideal sensors, Apollo 15 placement 0, seed 1, Sun 12/250 deg; "
             "`sensors only`: the same terrain seen through the flight sensors; `held out`: other terrain, seeds "
             "or Sun).",
             "Scores (docs/evaluation.md): Sim3 ATE and attitude drift after a Sim(3) fit; 1-frame RPE = median "
             "relative translation error between consecutive poses; RPE over 10 % of path = RMS relative translation "
             "error over pose pairs one tenth of the path length apart (fixed distance), in % of that distance; "
             "scale err = RMS of the windowed scale error "
             "(scale drift); end err, velocity err and end tilt after the first-pose alignment with the scale of "
             f"the first {FIRST_SCALE_WINDOW_S:g} s (the initial state handed over), except for the "
             "`lunar_altimeter` rows (vision + altimeter, metric): they are handed the first true pose only and "
             "scored without any alignment, velocity error of the motion filter's velocity, and the `lunar_imu` / `lunar_fused` rows (camera + IMU, with the "
             "altimeter): handed the first true pose and velocity, scored without any alignment, velocity error "
             "of the estimator's own velocity; ATE unaligned = ATE RMSE in m without any alignment (metric rows), "
             "NEES pos / att / vel = mean NEES of position and attitude (rows with a pose covariance: imu, fused, altimeter) "
             "and of the velocity (rows whose velocity has a covariance: altimeter, the motion filter's), 3 dof "
             "each, 3 when consistent; posed = frames with an estimated pose "
             "(TRACKING or RECOVERED, not coasted) / processed frames.",
             "Marks: correct = Sim3 ATE <= 1 % and attitude drift <= 0.5 deg; partial = ATE <= 5 %; failed = worse, "
             "or fewer than 90 % of the processed frames posed (lost).", "", tables, ""]
    # Everything under the generated table is written by hand: the "## ..." sections (earlier re-runs, "What the
    # table says") up to the plots. Keep all of it across runs; only the table and the plots are regenerated.
    results_md = os.path.join(docs, "results.md")
    if os.path.exists(results_md):
        with open(results_md) as f:
            old = f.read()
        start = old.find("\n## ")
        if start >= 0:
            end = old.find("\n![", start)
            lines += [old[start + 1:end if end >= 0 else len(old)].rstrip(), ""]
    for r in results:
        if r["config"] != "default" or r["group"] not in ("flight", "kitti", "heldout"):
            continue
        src = os.path.join(args.output, r.get("run_dir", ""), "plots", "trajectory.png")
        if os.path.exists(src):
            name = os.path.basename(os.path.dirname(r["run_dir"]))
            dst = os.path.join(plots, f"{name}.png")
            subprocess.call(["/usr/bin/convert", src, "-resize", "480x480", dst])
            lines += [f"![{name}](results/{name}.png)", ""]
    with open(results_md, "w") as f:
        f.write("\n".join(lines))
    print(f"wrote {results_md}")


if __name__ == "__main__":
    main()
