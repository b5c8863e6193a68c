#!/usr/bin/python3
"""The thesis' Table 4.8 with numbers: every Lunar sequence (and the KITTI clip) under every configuration.

For each sequence it renders the dataset once (lunar_render caches unchanged renders), runs vo_run with each
configuration, scores the trajectory with vo_eval (Sim(3) alignment) and marks the run:
  correct  ATE <= 1 % of the path length and rotation RMS <= 0.5 deg (attitude change since the first
           pose against ground truth, which does not depend on the alignment)
  partial  ATE <= 5 %
  failed   worse, or lost (the estimate covers less than 90 % of the processed frames)
It prints the table and, with --write-docs, writes docs/results.md with small trajectory plots.

Usage (after scripts/build.sh):
  /usr/bin/python3 scripts/vo_benchmark.py [--size 1024] [--duration S] [--sequences a,b] [--configs a,b]
                                            [--write-docs] [--output DIR]
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
CONFIGS = ["thesis_F", "thesis_E", "thesis_H", "default"]
CORRECT_ATE_PERCENT = 1.0
CORRECT_ROTATION_DEG = 0.5
PARTIAL_ATE_PERCENT = 5.0
MIN_COVERAGE = 0.9


def run(cmd, log_path):
    """Runs cmd, sending its output to log_path; returns (exit code, seconds)."""
    start = time.monotonic()
    with open(log_path, "w") as log:
        rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    return rc, time.monotonic() - start


def count_lines(path):
    if not os.path.exists(path):
        return 0
    with open(path) as f:
        return sum(1 for line in f if line.strip() and not line.startswith("#"))


def parse_vo_run_log(path):
    """Frame counts and the per-frame time of the whole process() call from vo_run's summary."""
    found = {}
    with open(path) as f:
        for line in f:
            m = re.search(r"(\d+) processed frames.* (\d+) poses ->", line)
            if m:
                processed, poses = int(m.group(1)), int(m.group(2))
                found["coverage"] = poses / max(1, processed)
            m = re.match(r"\s*total\s+([0-9.]+)\s+([0-9.]+)", line)
            if m:
                found["track_median_ms"], found["track_p99_ms"] = float(m.group(1)), float(m.group(2))
    return found


def mark(ate_percent, rotation_deg, coverage):
    if ate_percent is None or coverage < MIN_COVERAGE:
        return "failed (lost)" if ate_percent is not None else "failed"
    if ate_percent <= CORRECT_ATE_PERCENT and rotation_deg <= CORRECT_ROTATION_DEG:
        return "correct"
    if ate_percent <= PARTIAL_ATE_PERCENT:
        return "partial"
    return "failed"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--output", default=os.path.join(ROOT, "output", "benchmark"))
    ap.add_argument("--data", default=os.environ.get("PLANETARY_VO_DATA", os.path.join(ROOT, "..", "shared", "data")))
    ap.add_argument("--size", type=int, default=1024, help="rendered image side in pixels")
    ap.add_argument("--duration", type=float, default=0.0, help="render only the first S seconds (0 = all)")
    ap.add_argument("--sequences", default=",".join(LUNAR_SEQUENCES + ["kitti_clip_turn"]),
                    help="comma-separated NAME or NAME@SIZE (rendered image side for that sequence)")
    ap.add_argument("--configs", default=",".join(CONFIGS))
    ap.add_argument("--write-docs", action="store_true", help="write docs/results.md and its plots")
    args = ap.parse_args()

    bin_dir = os.path.join(args.build, "devel", "lib", "planetary_vo")
    for tool in ("lunar_render", "vo_run", "vo_eval"):
        if not os.path.exists(os.path.join(bin_dir, tool)):
            sys.exit(f"vo_benchmark: {tool} not found in {bin_dir}: build first (bash scripts/demo.sh builds)")
    os.makedirs(args.output, exist_ok=True)

    rows = []
    for spec in args.sequences.split(","):
        # NAME or NAME@SIZE: a Lunar sequence may be rendered at its own size (e.g. main_brake_down@512).
        sequence, _, size_text = spec.partition("@")
        size = int(size_text) if size_text else args.size
        if sequence == "kitti_clip_turn":
            dataset = os.path.join(args.data, "kitti_clip_turn")
        else:
            suffix = f"{size}px" + (f"_{args.duration:g}s" if args.duration > 0 else "")
            dataset = os.path.join(args.output, "sequences", f"{sequence}_{suffix}")
            cmd = [os.path.join(bin_dir, "lunar_render"), "--sequence", sequence, "--output", dataset,
                   "--width", str(size), "--height", str(size)]
            if args.duration > 0:
                cmd += ["--duration", str(args.duration)]
            os.makedirs(os.path.dirname(dataset), exist_ok=True)
            rc, secs = run(cmd, dataset + ".render.log")
            if rc != 0:
                sys.exit(f"vo_benchmark: rendering {sequence} failed, see {dataset}.render.log")
            print(f"[{sequence}] dataset ready ({secs:.0f} s)", flush=True)
        gt = os.path.join(dataset, "groundtruth.txt") if sequence != "kitti_clip_turn" else \
            os.path.join(dataset, "poses.txt")
        for config in args.configs.split(","):
            out = os.path.join(args.output, "runs", sequence, config)
            os.makedirs(out, exist_ok=True)
            traj = os.path.join(out, "trajectory.txt")
            run_log = os.path.join(out, "vo_run.log")
            rc, secs = run([os.path.join(bin_dir, "vo_run"), "--dataset", dataset,
                            "--config", os.path.join(ROOT, "config", config + ".yaml"),
                            "--output", traj], run_log)
            row = {"sequence": sequence, "size": "1241x376" if sequence == "kitti_clip_turn" else f"{size}x{size}",
                   "config": config, "ate_percent": None, "rotation_rms_deg": None,
                   "coverage": 0.0, "track_median_ms": None, "track_p99_ms": None, "vo_run_rc": rc}
            row.update(parse_vo_run_log(run_log))
            if rc == 0 and count_lines(traj) >= 3:
                ev_json = os.path.join(out, "eval.json")
                eval_cmd = [os.path.join(bin_dir, "vo_eval"), "--gt", gt, "--est", traj, "--align", "sim3",
                            "--json", ev_json]
                if args.write_docs:
                    eval_cmd += ["--plot", os.path.join(out, "plots")]
                erc, _ = run(eval_cmd, os.path.join(out, "vo_eval.log"))
                if erc == 0:
                    with open(ev_json) as f:
                        ev = json.load(f)
                    row["ate_percent"] = ev["ate_rmse_percent_of_path"]
                    row["rotation_rms_deg"] = ev["attitude_drift_deg"]["rmse"]
                    row["aligned_rotation_rms_deg"] = ev["rotation_error_deg"]["rmse"]
            row["mark"] = mark(row["ate_percent"], row["rotation_rms_deg"] or 0.0, row["coverage"])
            rows.append(row)
            print(format_row(row), flush=True)

    # Rows of sequences not run this time are kept from earlier runs into the same --output folder, so that a
    # long benchmark can be run a few sequences at a time.
    results_path = os.path.join(args.output, "results.json")
    run_now = {(r["sequence"], r["config"]) for r in rows}
    if os.path.exists(results_path):
        with open(results_path) as f:
            rows += [r for r in json.load(f) if (r["sequence"], r["config"]) not in run_now and "size" in r]
    order = LUNAR_SEQUENCES + ["kitti_clip_turn"]
    rows.sort(key=lambda r: (order.index(r["sequence"]) if r["sequence"] in order else len(order),
                             CONFIGS.index(r["config"]) if r["config"] in CONFIGS else len(CONFIGS)))
    table = format_table(rows, args)
    print()
    print(table)
    with open(results_path, "w") as f:
        json.dump(rows, f, indent=1)
    if args.write_docs:
        write_docs(table, rows, args)


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def format_row(r):
    return (f"| {r['sequence']} | {r['size']} | {r['config']} | {fmt(r['ate_percent'], '.3f')} | "
            f"{fmt(r['rotation_rms_deg'], '.3f')} | {r['coverage'] * 100:.0f} % | {r['mark']} | "
            f"{fmt(r['track_median_ms'], '.1f')} / {fmt(r['track_p99_ms'], '.1f')} |")


def format_table(rows, args):
    head = ("| sequence | image | configuration | ATE % of path (Sim3) | rotation RMS deg | frames with a pose | mark | "
            "ms/frame median / p99 |\n|---|---|---|---|---|---|---|---|")
    return head + "\n" + "\n".join(format_row(r) for r in rows)


def write_docs(table, rows, args):
    docs = os.path.join(ROOT, "docs")
    plots = os.path.join(docs, "results")
    os.makedirs(plots, exist_ok=True)
    lines = ["# VO benchmark results (thesis Table 4.8, with numbers)", "",
             "Produced by one command from a clean clone (after `bash scripts/demo.sh` has built the tools):", "",
             "```sh", "/usr/bin/python3 scripts/vo_benchmark.py " + " ".join(sys.argv[1:]), "```", "",
             ("First " + f"{args.duration:g} s of each Lunar sequence." if args.duration else
              "Full Lunar sequences (10 Hz), at the image size given in the table; KITTI clip at its own size."),
             "Marks: correct = ATE <= 1 % and rotation RMS <= 0.5 deg; partial = ATE <= 5 %; failed = worse, or "
             "a pose for fewer than 90 % of the processed frames (lost).", "", table, ""]
    # The reading of the numbers is written by hand under "## What the table says"; keep it across runs.
    results_md = os.path.join(docs, "results.md")
    if os.path.exists(results_md):
        with open(results_md) as f:
            old = f.read()
        start = old.find("## What the table says")
        if start >= 0:
            end = old.find("\n![", start)
            lines += [old[start:end if end >= 0 else len(old)].rstrip(), ""]
    for r in rows:
        if r["config"] != "default":
            continue
        src = os.path.join(args.output, "runs", r["sequence"], r["config"], "plots", "trajectory.png")
        if os.path.exists(src):
            dst = os.path.join(plots, f"{r['sequence']}.png")
            subprocess.call(["/usr/bin/convert", src, "-resize", "480x480", dst])
            lines += [f"![{r['sequence']}](results/{r['sequence']}.png)", ""]
    with open(os.path.join(docs, "results.md"), "w") as f:
        f.write("\n".join(lines))
    print(f"wrote {os.path.join(docs, 'results.md')}")


if __name__ == "__main__":
    main()
