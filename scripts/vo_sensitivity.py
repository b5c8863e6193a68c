#!/usr/bin/python3
"""Sensitivity of the VO to its main parameters (issue 13; thesis 5.1 Phase 1): one parameter at a time.

For every parameter in PARAMETERS, each of its values is set in the base configuration (all other parameters at
their base values) and vo_run is run on every dataset of the chosen benchmark groups (the datasets of
scripts/vo_benchmark.py, rendered by lunar_render the same way and cached, so the images are the benchmark's).
Each trajectory is scored with vo_eval (Sim(3) ATE in % of the path). The summary gives, per parameter and
sequence, the ATE of every value, the best value, and the worst ratio to the best over the range: a ratio above
CLIFF_RATIO (2) is a cliff. A run that loses track (fewer than 90 % of the frames posed) or fails is a cliff too.

  /usr/bin/python3 scripts/vo_sensitivity.py [--groups ideal512,kitti] [--params features,grid,...]
        [--base-config config/default.yaml] [--jobs N] [--output output/sensitivity] [--write-docs docs/sensitivity]
        [--starts N]           (N runs per dataset, vo_run --first-frame 0..N-1; the median decides)
        [--datasets DIR,...]   (any planetary_vo datasets with ground truth instead of the benchmark's)
        [--campaigns DIR,...]  (the rendered runs of scripts/vo_campaign.py folders: dispersed renders per sequence)

With --starts N (N > 1) every setting runs N times on each dataset, from input image 0, 1, ... N-1 (vo_run
--first-frame), and a sequence's figure is the median over those runs, as over a campaign's renders below: one
run's ATE moves by up to 3x with where it starts, which a single run per setting would read as a cliff.

With --campaigns every setting runs on every dispersed render of each campaign (terrain seed, DEM placement, Sun,
sensor seed: docs/campaigns.md), and a sequence's figure is the MEDIAN Sim(3) ATE over its renders (a lost run
counts as infinitely bad), so that one render's luck does not decide: the ratio is that median over the best
median of the range, a cliff above CLIFF_RATIO, or when a setting loses a render the best one does not. The
summary also gives each setting's 90th percentile and its lost renders; the plots show the median with the
25-75 % band.

Files in --output (--write-docs copies summary.md and plots/): configs/*.yaml (one per setting), runs/SETTING/DATASET/{trajectory.txt,vo_run.log,eval.json},
results.json, summary.md, plots/PARAMETER.png. A vo_run whose trajectory is newer than its configuration, dataset
and binary is reused (--rerun to run everything again). The trajectories do not depend on timing (the asynchronous
bundle adjustment is waited for at fixed points), so --jobs changes the wall time only; the per-frame times in
the summary are measured with --jobs runs sharing the machine and are indicative only.
"""
import argparse
import concurrent.futures
import copy
import json
import math
import os
import shutil
import sys
import time

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vo_benchmark as bench  # noqa: E402  (the benchmark's rows, dataset names, render call and log parser)

ROOT = bench.ROOT
CLIFF_RATIO = 2.0

# name: (configuration keys set together, values, log x axis, what it is). The ranges are issue 13's.
PARAMETERS = {
    "features": (["detector.num_features"], [150, 300, 600, 1000, 2000], True,
                 "feature budget of a full detection"),
    "grid": (["detector.grid_cols", "detector.grid_rows"], [4, 6, 8, 12], False,
             "detection grid, cells per side"),
    "lk_window": (["tracker.window_size_px"], [11, 15, 21, 31], False, "LK window side, px"),
    "lk_levels": (["tracker.pyramid_levels"], [1, 2, 3, 4], False, "pyramid levels above full resolution (LK and anchor alignment)"),
    "kf_parallax": (["keyframe.min_parallax_deg"], [1.0, 2.0, 3.0, 5.0, 8.0], False,
                    "keyframe parallax, deg"),
    "kf_track_ratio": (["keyframe.min_track_ratio"], [0.5, 0.7, 0.8, 0.9], False,
                       "keyframe track ratio"),
    "ba_window": (["map.window_keyframes", "bundle_adjustment.window_keyframes"], [5, 7, 10, 15], False,
                  "local map and BA window, keyframes"),
    # The anchor-alignment tracker's own keys (tracker.method auto / anchor_alignment; LK's window and levels do not
    # act on the Lunar renders where auto aligns anchors, but the pyramid levels do).
    "anchor_patch": (["tracker.anchor_patch_px"], [7, 9, 11, 15], False, "anchor patch side, px"),
    "anchor_age": (["tracker.anchor_max_age_frames"], [5, 10, 20, 40], True, "anchor renewal age, frames"),
    "align_residual": (["tracker.alignment_max_residual_ratio"], [0.4, 0.5, 0.6, 0.8], False,
                       "anchor alignment residual ratio"),
}


def get_key(config, key):
    section, name = key.split(".")
    return config[section][name]


def set_key(config, key, value):
    section, name = key.split(".")
    if section not in config or name not in config[section]:
        raise KeyError(f"{key} is not in the base configuration")
    config[section][name] = type(config[section][name])(value)


def setting_name(param, value):
    return f"{param}_{value:g}"


def datasets(groups, output, data):
    """(name, dataset dir, ground truth, row) of each benchmark dataset of the groups, monocular rows only."""
    out = []
    for row in bench.default_rows():
        if row["group"] not in groups or row.get("metric"):
            continue
        if row["sequence"] == "kitti_clip_turn":
            d = os.path.join(data, "kitti_clip_turn")
            out.append(("kitti_clip_turn", d, os.path.join(d, "poses.txt"), row))
        else:
            name = bench.dataset_name(row, 0.0)
            d = os.path.join(output, "sequences", name)
            out.append((name, d, d, row))
    return out


def campaign_datasets(campaign_dirs):
    """(name, dataset dir, ground truth, family) of every completed render of vo_campaign.py folders; the
    family (one per campaign) is what the summary aggregates over."""
    out = []
    for c in campaign_dirs:
        c = os.path.abspath(c)
        with open(os.path.join(c, "runs.json")) as f:
            plan = json.load(f)
        family = f"{plan['sequence']}_{plan['size_px']}px_{plan['sensors']}"
        if plan.get("duration_s"):
            family += f"_{plan['duration_s']:g}s"
        for run in plan["runs"]:
            d = os.path.join(c, "runs", run["id"], "dataset")
            render = os.path.join(c, "runs", run["id"], "render.json")
            ok = os.path.isfile(os.path.join(d, "times.txt")) and os.path.isfile(render)
            if ok:
                with open(render) as f:
                    ok = json.load(f).get("rc") == 0
            if ok:
                out.append((f"{plan['name']}.{run['id']}", d, d, family))
    return out


def run_one(job):
    """vo_run + vo_eval of one (setting, dataset); returns the result dict."""
    setting, config_path, name, dataset, gt, bin_dir, run_dir, rerun, first_frame, sequence = job
    os.makedirs(run_dir, exist_ok=True)
    traj = os.path.join(run_dir, "trajectory.txt")
    log = os.path.join(run_dir, "vo_run.log")
    eval_json = os.path.join(run_dir, "eval.json")
    stamp = gt if name == "kitti_clip_turn" else os.path.join(dataset, "render_stamp.txt")
    if not os.path.exists(stamp):
        stamp = os.path.join(dataset, "times.txt")
    vo_run = os.path.join(bin_dir, "vo_run")
    started = time.monotonic()
    cmd = [vo_run, "--dataset", dataset, "--config", config_path, "--output", traj]
    if first_frame > 0:
        cmd += ["--first-frame", str(first_frame)]
    rc, reused = bench.run_vo(cmd, log, traj, [stamp, config_path, vo_run], rerun)
    r = {"setting": setting, "dataset": name, "vo_run_rc": rc, "reused": reused, "coverage": 0.0,
         "seconds": time.monotonic() - started}
    r.update(bench.parse_vo_run_log(log))
    scored = bench.eval_sim3(bin_dir, gt, traj, sequence, eval_json, os.path.join(run_dir, "vo_eval.log")) \
        if rc == 0 else None
    if scored:
        r.update(bench.eval_metrics(scored, None))
    r["ok"] = r.get("ate_percent") is not None and r["coverage"] >= bench.MIN_COVERAGE
    return r


def analyse(results, params, names, base):
    """Per parameter and dataset: ATE per value, best, worst ratio to the best, cliff."""
    by = {(r["setting"], r["dataset"]): r for r in results}
    table = {}
    for p in params:
        keys, values, _, _ = PARAMETERS[p]
        default = get_key(base, keys[0])
        per = {}
        for name in names:
            ates = []
            for v in values:
                r = by.get((setting_name(p, v), name))
                ates.append(r["ate_percent"] if r and r["ok"] else None)
            valid = [a for a in ates if a is not None]
            best = min(valid) if valid else None
            ratios = [(a / best if a is not None and best else math.inf) for a in ates]
            worst = max(ratios)
            worst_value = values[ratios.index(worst)]
            per[name] = {"ate": ates, "best": best, "best_value": values[ates.index(best)] if best else None,
                         "ratios": ratios, "worst_ratio": worst, "worst_value": worst_value,
                         "cliff": worst > CLIFF_RATIO, "default_ratio": ratios[values.index(default)]
                         if default in values else None}
        table[p] = {"values": values, "default": default, "keys": keys, "per_dataset": per}
    return table


def percentile(values, q):
    """Linear-interpolated percentile of a list that may hold math.inf (lost runs sort last)."""
    v = sorted(values)
    if not v:
        return None
    pos = (len(v) - 1) * q
    lo, hi = int(math.floor(pos)), int(math.ceil(pos))
    if v[hi] == math.inf:
        return math.inf if pos > lo or v[lo] == math.inf else v[lo]
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def analyse_families(results, params, families, base):
    """Per parameter and family of dispersed renders: per value the median, quartiles and 90th percentile
    of the ATE over the renders (lost = inf) and the lost count; the ratio of each median to the best."""
    by = {(r["setting"], r["dataset"]): r for r in results}
    table = {}
    for p in params:
        keys, values, _, _ = PARAMETERS[p]
        default = get_key(base, keys[0])
        per = {}
        for family, names in families.items():
            stats = []
            for v in values:
                ates = []
                for n in names:
                    r = by.get((setting_name(p, v), n))
                    ates.append(r["ate_percent"] if r and r["ok"] else math.inf)
                stats.append({"median": percentile(ates, 0.5), "q25": percentile(ates, 0.25),
                              "q75": percentile(ates, 0.75), "p90": percentile(ates, 0.9),
                              "lost": sum(a == math.inf for a in ates), "runs": len(ates)})
            medians = [st["median"] for st in stats]
            best = min(medians)
            best_i = medians.index(best)
            ratios = [m / best if best not in (0, math.inf) else math.inf for m in medians]
            worst = max(ratios)
            # A setting that loses a render the best setting keeps is a cliff whatever its median.
            lost_cliff = [st["lost"] > stats[best_i]["lost"] for st in stats]
            cliff_values = [v for v, r, lc in zip(values, ratios, lost_cliff) if r > CLIFF_RATIO or lc]
            per[family] = {"stats": stats, "medians": medians, "best": best, "best_value": values[best_i],
                           "ratios": ratios, "worst_ratio": worst, "worst_value": values[ratios.index(worst)],
                           "cliff": bool(cliff_values), "cliff_values": cliff_values,
                           "default_ratio": ratios[values.index(default)] if default in values else None}
        table[p] = {"values": values, "default": default, "keys": keys, "per_dataset": per}
    return table


def summary_families(table, families, args, results, wall_s):
    """The summary of a sweep whose sequences each have several runs: the renders of a campaign (--campaigns)
    or several starts of one render (--starts)."""
    def ate_cell(x):
        return "lost" if x is None or x == math.inf else f"{x:.3f}"

    n_runs = {f: len(n) for f, n in families.items()}
    if args.campaigns:
        title, source, unit = "over dispersed renders", f"--campaigns {args.campaigns}", "render"
        per_sequence = ("Renders per sequence: " + ", ".join(f"{f}: {n}" for f, n in n_runs.items())
                        + " (each a vo_campaign.py run: its own terrain seed, DEM placement, Sun elevation and "
                        "azimuth, sensor seed; docs/campaigns.md).")
    else:
        title = f"over {args.starts} starts per sequence"
        source = (f"--datasets {args.datasets}" if args.datasets else f"--groups {args.groups}") + \
            f" --starts {args.starts}"
        unit = "run"
        per_sequence = (f"Runs per sequence: {args.starts}, `vo_run --first-frame 0..{args.starts - 1}` on the same "
                        "images: a single run's ATE moves by up to 3x with the image it starts at "
                        "(docs/visual_core.md, step 6), so one run per setting cannot tell a cliff from that "
                        "spread.")
    lines = [f"# Sensitivity of the VO to its main parameters, {title}", "",
             f"Generated by `scripts/vo_sensitivity.py {source} --params {args.params} "
             f"--base-config {os.path.relpath(os.path.abspath(args.base_config), ROOT)}` ({len(results)} (setting, "
             f"{unit}) results from the runs of {len({r['setting'] for r in results if 'shares_runs_of' not in r})}"
             f" distinct configurations; this invocation {wall_s / 60:.0f} min wall with --jobs {args.jobs}, "
             f"{sum(1 for r in results if r.get('reused') and 'shares_runs_of' not in r)} vo_run trajectories "
             "reused from an earlier one).",
             per_sequence + " One parameter at a time; all others at the base configuration's values.",
             f"Cell: the MEDIAN Sim(3) ATE over the {unit}s in % of the path (`vo_eval --align sim3`; a {unit} "
             f"lost, < 90 % of its frames posed, counts as infinitely bad), with the {unit}s lost in brackets. "
             f"Ratio = that median / the best median of the parameter's range; a cliff is a ratio above "
             f"{CLIFF_RATIO:g}, or a setting that loses a {unit} the best setting keeps. **Bold** = the base "
             "value.", ""]
    lines += ["## Worst ratio to the best setting, per parameter and sequence", "",
              "| parameter | range | " + " | ".join(families) + " | cliffs |", "|---" * (len(families) + 3) + "|"]
    for p, t in table.items():
        cells, cliffs = [], 0
        for f in families:
            d = t["per_dataset"][f]
            cell = fmt_ratio(d["worst_ratio"]) + f" @{d['worst_value']:g}"
            lost = [f"{v:g}" for v, st in zip(t["values"], d["stats"]) if st["lost"]]
            if lost:
                cell += " (lost at " + ", ".join(lost) + ")"
            if d["cliff"]:
                cell = f"**{cell}**"
                cliffs += 1
            cells.append(cell)
        lines.append(f"| {p} | {t['values'][0]:g}-{t['values'][-1]:g} | " + " | ".join(cells) + f" | {cliffs} |")
    lines.append("")
    for p, t in table.items():
        keys, values, _, what = PARAMETERS[p]
        lines += [f"## {p}: {what} (`{'`, `'.join(keys)}`)", "", f"![{p}](plots/{p}.png)", "",
                  "| sequence | statistic | " + " | ".join((f"**{v:g}**" if v == t["default"] else f"{v:g}")
                                                         for v in values) + " | best |",
                  "|---" * (len(values) + 3) + "|"]
        for f in families:
            d = t["per_dataset"][f]
            lines.append(f"| {f} | median (lost) | " + " | ".join(
                ate_cell(st["median"]) + (f" ({st['lost']})" if st["lost"] else "") for st in d["stats"])
                + f" | {d['best_value']:g} |")
            lines.append("| | 90th percentile | " + " | ".join(ate_cell(st["p90"]) for st in d["stats"]) + " | |")
            lines.append("| | ratio to best | " + " | ".join(fmt_ratio(r) for r in d["ratios"]) + " | |")
        lines.append("")
    return "\n".join(lines) + "\n"


def plot_families(table, families, out_dir, what="over dispersed renders", unit="a render"):
    def draw(ax1, ax2, t, values):
        for f in families:
            d = t["per_dataset"][f]
            pts = [(v, st) for v, st in zip(values, d["stats"]) if st["median"] != math.inf]
            xs = [v for v, _ in pts]
            line, = ax1.plot(xs, [st["median"] for _, st in pts], marker="o",
                             label=f"{f} (median of {d['stats'][0]['runs']})")
            q75 = [st["q75"] if st["q75"] != math.inf else None for _, st in pts]
            if all(q is not None for q in q75):
                ax1.fill_between(xs, [st["q25"] for _, st in pts], q75, color=line.get_color(), alpha=0.2)
            ax2.plot(xs, [r for r in d["ratios"] if r != math.inf], marker="o", color=line.get_color(), label=f)
            lost = [v for v, st in zip(values, d["stats"]) if st["lost"]]
            if lost:
                ax2.plot(lost, [CLIFF_RATIO * 1.5] * len(lost), "kx", markersize=9)
    plot_each_parameter(table, out_dir, draw, "Sim(3) ATE, % of path: median, 25-75 %",
                        f"median / best median (x = {unit} lost)", ", " + what, ate_legend=True)


def fmt_ratio(x):
    return "fail" if x == math.inf else f"{x:.2f}"


def summary_markdown(table, names, args, results, wall_s):
    by = {(r["setting"], r["dataset"]): r for r in results}
    lines = ["# Sensitivity of the VO to its main parameters", "",
             "Generated by `scripts/vo_sensitivity.py "
             + (f"--datasets {','.join(names)}" if args.datasets else f"--groups {args.groups}")
             + f" --params {args.params} "
             f"--base-config {os.path.relpath(args.base_config, ROOT)}` "
             f"({len(results)} (setting, dataset) results from the runs of "
             f"{len({r['setting'] for r in results if 'shares_runs_of' not in r})} distinct configurations; "
             f"this invocation {wall_s / 60:.0f} min wall with --jobs {args.jobs}, "
             f"{sum(1 for r in results if r.get('reused') and 'shares_runs_of' not in r)} vo_run trajectories "
             "reused from an earlier one).",
             "One parameter at a time; all others at the base configuration's values. Cell: Sim(3) ATE in % of the "
             "path (`vo_eval --align sim3`); *fail* = lost (< 90 % of frames posed) or no trajectory. "
             f"Ratio = ATE / the best ATE of that parameter's range on that dataset; above {CLIFF_RATIO:g} is a "
             "cliff. **Bold** = the base value.", ""]
    lines += ["## Worst ratio to the best setting, per parameter and dataset", "",
              "| parameter | range | " + " | ".join(names) + " | cliffs |",
              "|---" * (len(names) + 3) + "|"]
    for p, t in table.items():
        cells = []
        cliffs = 0
        for n in names:
            d = t["per_dataset"][n]
            cell = fmt_ratio(d["worst_ratio"]) + f" @{d['worst_value']:g}"
            if d["cliff"]:
                cell = f"**{cell}**"
                cliffs += 1
            cells.append(cell)
        rng = f"{t['values'][0]:g}-{t['values'][-1]:g}"
        lines.append(f"| {p} | {rng} | " + " | ".join(cells) + f" | {cliffs} |")
    lines.append("")
    for p, t in table.items():
        keys, values, _, what = PARAMETERS[p]
        lines += [f"## {p}: {what} (`{'`, `'.join(keys)}`)", "", f"![{p}](plots/{p}.png)", "",
                  "| dataset | " + " | ".join((f"**{v:g}**" if v == t["default"] else f"{v:g}") for v in values)
                  + " | best | worst ratio |", "|---" * (len(values) + 3) + "|"]
        for n in names:
            d = t["per_dataset"][n]
            cells = ["fail" if a is None else f"{a:.3f}" for a in d["ate"]]
            best = "-" if d["best"] is None else f"{d['best_value']:g}"
            lines.append(f"| {n} | " + " | ".join(cells) + f" | {best} | {fmt_ratio(d['worst_ratio'])} |")
        # The per-frame cost of the whole vo_run frame (median over the datasets' medians) beside the accuracy.
        costs = []
        for v in values:
            meds = [by[(setting_name(p, v), n)].get("track_median_ms") for n in names
                    if by.get((setting_name(p, v), n), {}).get("track_median_ms")]
            costs.append(f"{sorted(meds)[len(meds) // 2]:.1f}" if meds else "-")
        lines.append("| *frame time, median of the datasets' medians, ms* | " + " | ".join(costs) + " | | |")
        lines.append("")
    return "\n".join(lines) + "\n"


def has_positive_data(ax):
    return any(math.isfinite(y) and y > 0 for line in ax.get_lines() for y in line.get_ydata())


def plot_each_parameter(table, out_dir, draw, ate_label, ratio_label, title_suffix="", ate_legend=False):
    """One figure per parameter, absolute ATE left and ratio to the best right: draw(ax1, ax2, t, values) plots
    the series; the axes, the base value, the cliff line and the file are the same for both kinds of sweep."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    os.makedirs(out_dir, exist_ok=True)
    for p, t in table.items():
        keys, values, logx, what = PARAMETERS[p]
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
        draw(ax1, ax2, t, values)
        # A parameter whose every run was lost has nothing to put on a log scale (matplotlib would raise).
        log_ate, log_ratio = has_positive_data(ax1), has_positive_data(ax2)
        for ax in (ax1, ax2):
            ax.axvline(t["default"], color="grey", linestyle=":", label="base value")
            ax.set_xlabel(what)
            if logx:
                ax.set_xscale("log")
            ax.set_xticks(values)
            ax.set_xticklabels([f"{v:g}" for v in values])
            ax.grid(True, alpha=0.3)
        if log_ate:
            ax1.set_yscale("log")
        ax1.set_ylabel(ate_label)
        if ate_legend:
            ax1.legend(fontsize=7, loc="upper left")
        ax2.axhline(CLIFF_RATIO, color="red", linestyle="--", label=f"cliff ({CLIFF_RATIO:g}x best)")
        if log_ratio:
            ax2.set_yscale("log")
        ax2.set_ylabel(ratio_label)
        ax2.legend(fontsize=7, loc="upper left")
        fig.suptitle(f"{p}: {'/'.join(keys)}{title_suffix}")
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, p + ".png"), dpi=80)
        plt.close(fig)


def plot(table, names, out_dir):
    def draw(ax1, ax2, t, values):
        for n in names:
            d = t["per_dataset"][n]
            xs = [v for v, a in zip(values, d["ate"]) if a is not None]
            ax1.plot(xs, [a for a in d["ate"] if a is not None], marker="o", label=n)
            ax2.plot(xs, [r for r in d["ratios"] if r != math.inf], marker="o", label=n)
            fails = [v for v, a in zip(values, d["ate"]) if a is None]
            if fails:
                ax2.plot(fails, [CLIFF_RATIO * 1.5] * len(fails), "kx", markersize=9)
    plot_each_parameter(table, out_dir, draw, "Sim(3) ATE, % of path", "ATE / best ATE of the range (x = lost)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--data", default=os.environ.get("PLANETARY_VO_DATA", os.path.join(ROOT, "..", "shared", "data")))
    ap.add_argument("--benchmark-output", default=os.path.join(ROOT, "output", "benchmark"),
                    help="where the benchmark's datasets are (and are rendered when missing)")
    ap.add_argument("--output", default=os.path.join(ROOT, "output", "sensitivity"))
    ap.add_argument("--groups", default="ideal512,kitti", help="benchmark groups (vo_benchmark.py); monocular rows")
    ap.add_argument("--sequences", default="", help="comma-separated dataset names to keep (default: all)")
    ap.add_argument("--datasets", default="",
                    help="comma-separated planetary_vo dataset folders with ground truth, instead of --groups")
    ap.add_argument("--campaigns", default="",
                    help="comma-separated vo_campaign.py folders: every completed render of each, aggregated per "
                         "campaign (median over the renders), instead of --groups")
    ap.add_argument("--starts", type=int, default=1,
                    help="runs per dataset and setting (vo_run --first-frame 0..N-1); with N > 1 a sequence's "
                         "figure is the median over its runs, as over a campaign's renders")
    ap.add_argument("--params", default=",".join(PARAMETERS), help="parameters (" + ", ".join(PARAMETERS) + ")")
    ap.add_argument("--base-config", default=os.path.join(ROOT, "config", "default.yaml"))
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--rerun", action="store_true", help="run vo_run even where its trajectory is current")
    ap.add_argument("--write-docs", default="", help="copy summary.md and plots/ to this folder")
    args = ap.parse_args()

    params = args.params.split(",")
    if args.starts < 1:
        sys.exit(f"vo_sensitivity: --starts needs at least 1, got {args.starts}")
    if args.starts > 1 and args.campaigns:
        sys.exit("vo_sensitivity: --starts and --campaigns do not go together (a campaign's renders are its runs)")
    for p in params:
        if p not in PARAMETERS:
            sys.exit(f"vo_sensitivity: unknown parameter {p} (known: {', '.join(PARAMETERS)})")
    bin_dir = os.path.join(args.build, "devel", "lib", "planetary_vo")
    for tool in ("vo_run", "vo_eval") + (() if args.datasets or args.campaigns else ("lunar_render",)):
        if not os.path.exists(os.path.join(bin_dir, tool)):
            sys.exit(f"vo_sensitivity: {tool} not found in {bin_dir}: build first (bash scripts/demo.sh builds)")
    with open(args.base_config) as f:
        base = yaml.safe_load(f)
    families = {}
    if args.campaigns:
        sets = []
        for name, d, gt, family in campaign_datasets(args.campaigns.split(",")):
            sets.append((name, d, gt, None))
            families.setdefault(family, []).append(name)
    elif args.datasets:
        sets = []
        for d in args.datasets.split(","):
            d = os.path.abspath(d)
            if not os.path.isfile(os.path.join(d, "times.txt")):
                sys.exit(f"vo_sensitivity: {d} is not a dataset folder (no times.txt)")
            sets.append((os.path.basename(d.rstrip("/")), d, d, None))
    else:
        sets = datasets(args.groups.split(","), args.benchmark_output, args.data)
    if args.sequences:
        keep = set(args.sequences.split(","))
        sets = [s for s in sets if s[0] in keep]
    if not sets:
        sys.exit("vo_sensitivity: no dataset in these groups")
    # (run name, dataset, ground truth, first frame, sequence): with --starts every dataset is a family of runs.
    runs = []
    for name, dataset, gt, _ in sets:
        if args.starts > 1:
            for n in range(args.starts):
                runs.append((f"{name}.start{n}", dataset, gt, n, name))
                families.setdefault(name, []).append(f"{name}.start{n}")
        else:
            runs.append((name, dataset, gt, 0, name))
    started = time.monotonic()

    # The datasets, rendered once (lunar_render skips an unchanged render).
    for name, dataset, _, row in sets:
        if row is None or name == "kitti_clip_turn":
            continue
        os.makedirs(os.path.dirname(dataset), exist_ok=True)
        rc, secs = bench.run(bench.render_command(row, bin_dir, dataset, 0.0), dataset + ".render.log")
        if rc != 0:
            sys.exit(f"vo_sensitivity: rendering {name} failed, see {dataset}.render.log")

    # One configuration per (parameter, value). Settings with the same configuration (every parameter's base
    # value is the base configuration) are run once: the trajectories are deterministic.
    config_dir = os.path.join(args.output, "configs")
    os.makedirs(config_dir, exist_ok=True)
    jobs = []
    same_as = {}  # setting -> the setting whose runs it shares
    by_text = {}
    for p in params:
        keys, values, _, _ = PARAMETERS[p]
        for v in values:
            config = copy.deepcopy(base)
            for k in keys:
                set_key(config, k, v)
            setting = setting_name(p, v)
            text = yaml.safe_dump(config, sort_keys=False)
            if text in by_text:
                same_as[setting] = by_text[text]
                continue
            by_text[text] = setting
            path = os.path.join(config_dir, setting + ".yaml")
            if not os.path.exists(path) or open(path).read() != text:
                with open(path, "w") as f:
                    f.write(text)
            for name, dataset, gt, first_frame, sequence in runs:
                jobs.append((setting, path, name, dataset, gt, bin_dir,
                             os.path.join(args.output, "runs", setting, name), args.rerun, first_frame, sequence))

    results = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(run_one, j) for j in jobs]
        for i, fut in enumerate(concurrent.futures.as_completed(futures), 1):
            r = fut.result()
            results.append(r)
            ate = "fail" if not r["ok"] else f"{r['ate_percent']:.3f} %"
            took = "reused" if r["reused"] else f"{r['seconds']:.0f} s"
            print(f"[{i}/{len(jobs)}] {r['setting']:<20} {r['dataset']:<32} ATE {ate:<10} "
                  f"posed {r['coverage'] * 100:.0f} %  {took}"
                  f"  elapsed {(time.monotonic() - started) / 60:.1f} min", flush=True)

    for setting, shared in same_as.items():
        results += [dict(r, setting=setting, shares_runs_of=shared) for r in results if r["setting"] == shared]
    names = [r[0] for r in runs]
    wall = time.monotonic() - started
    if families:
        table = analyse_families(results, params, families, base)
        summary = summary_families(table, families, args, results, wall)
    else:
        table = analyse(results, params, names, base)
        summary = summary_markdown(table, names, args, results, wall)
    with open(os.path.join(args.output, "results.json"), "w") as f:
        json.dump({"results": results, "analysis": table}, f, indent=1, default=str)
    with open(os.path.join(args.output, "summary.md"), "w") as f:
        f.write(summary)
    if families:
        if args.campaigns:
            plot_families(table, families, os.path.join(args.output, "plots"))
        else:
            plot_families(table, families, os.path.join(args.output, "plots"),
                          f"over {args.starts} starts per sequence", "a run")
    else:
        plot(table, names, os.path.join(args.output, "plots"))
    print(summary)
    cliffs = sum(d["cliff"] for t in table.values() for d in t["per_dataset"].values())
    print(f"vo_sensitivity: {len(results)} runs in {wall / 60:.1f} min; {cliffs} (parameter, dataset) pairs with a "
          f"cliff (> {CLIFF_RATIO:g}x the best ATE of the range, or lost)")
    if args.write_docs:
        os.makedirs(args.write_docs, exist_ok=True)
        shutil.copy(os.path.join(args.output, "summary.md"), args.write_docs)
        shutil.copytree(os.path.join(args.output, "plots"), os.path.join(args.write_docs, "plots"),
                        dirs_exist_ok=True)


if __name__ == "__main__":
    main()
