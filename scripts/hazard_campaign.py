#!/usr/bin/python3
"""Landing-site safety campaign (issue 11): is every site the hazard map chooses truly safe?

For each rendered dataset (with its groundtruth_terrain grids): one fused navigation run with the hazard map
(`vo_run --config config/lunar_fused.yaml --initial-state-from-groundtruth --output-terrain DIR`, the map at the
end of the sequence), then, for each target on a grid over the landing area, `terrain_eval` chooses the best site
within reach of that target on the estimated map (findLandingSites with the map's own sigmas; confidence k and
the rest from config/hazard.yaml unless given) and checks it against the true terrain (every true cell within the
clearance known and safe). Each site is judged twice: at its world coordinates, and at touchdown: moved by the
navigation's error at the end of the run (terrain_eval --navigation-error-from), where a lander guided by this
navigation to the site lands, on the ground the map saw there (terrain/terrain_score.h, truthInNavigationFrame).
The maps are scored both ways too.

Two ways to get the datasets:
  --datasets DIR [DIR ...]   renders that exist (e.g. the benchmark's);
  --runs N                   a Monte Carlo campaign: N renders drawn from the campaign seed, each with its own
                             terrain seed, DEM placement, Sun elevation and azimuth and sensor seed (the
                             dispersions and the draw of scripts/vo_campaign.py, docs/campaigns.md), the
                             sequences taken in turn. To keep 50 renders of 1024 px affordable, a run renders
                             only the end of the approach (--start-s, default 40 s: 184 m above the ground, where
                             the ground the map is built from starts to be seen at its resolution) and hands the
                             navigation its state there with a dispersed error (--init-position-sigma-m per axis,
                             --init-attitude-sigma-deg): the fused navigation's own error at 40 s of the full
                             approach, 1.0-2.0 m on the three flight renders (docs/terrain/README.md).

Each (dataset, target) pair is one trial. Trials on one dataset share its map, so they are not independent: the
summary counts them, the distinct sites, and, per dataset, the site chosen for the planned target (0, 0). Prints a
table and a summary; --json writes every trial; with --runs, OUT/summary.md and OUT/summary.json.

  scripts/hazard_campaign.py --datasets DIR [DIR ...] [--out output/hazard_campaign] [common options]
  scripts/hazard_campaign.py --runs 50 [--seed 1] [--sequences approach_down,approach_30deg,approach_nozzle]
                             [--size 1024] [--start-s 40] [--sensors flight] [--jobs 2] [--keep-images]
                             [--renders-from CAMPAIGN] [common]
  --renders-from: the navigation and the hazard map run again on the renders of an earlier campaign of the same
  draws (one run with --keep-images), e.g. to measure a change of the code or of --hazard-config on the same images;
  each run's draw must equal the earlier one's. Each run's folder gets a link `dataset` to the render it used.
  common: [--confidence-k K] [--targets "x,y;x,y;..."] [--hazard-config FILE] [--max-shadow-fraction F]
          [--max-shading-slope-deg S] [--shading-slope-weight W] [--shading-margin-m M]
          [--reuse] [--json FILE] [--write-docs DIR]
"""
import argparse
import concurrent.futures
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vo_campaign  # noqa: E402  (the dispersions and their draw: one place)

BUILD = os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build"))
BIN = os.path.join(BUILD, "devel", "lib", "planetary_vo")
# Targets 64 m apart over the 256 m landing area: nine per dataset; (0, 0) is the planned site.
DEFAULT_TARGETS = [(x, y) for y in (-64.0, 0.0, 64.0) for x in (-64.0, 0.0, 64.0)]
MAP_KEYS = ["surface_coverage", "slope_rmse_deg", "hazard_precision", "hazard_recall", "slope_within_2sigma"]
PRINT_LOCK = threading.Lock()


class ToolFailed(Exception):
    pass


def run(cmd, log):
    with open(log, "w") as out:
        out.write("$ " + " ".join(cmd) + "\n")
        out.flush()
        rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    if rc != 0:
        raise ToolFailed("%s failed (rc %d), see %s" % (os.path.basename(cmd[0]), rc, log))


def say(text):
    with PRINT_LOCK:
        print(text)
        sys.stdout.flush()


def read_plan(ap, folder):
    """An earlier campaign's plan.json: (the plan, {"argv", "runs"}; its command line parsed by `ap`). Exits with a
    message when the file is missing or malformed."""
    try:
        with open(os.path.join(folder, "plan.json")) as f:
            plan = json.load(f)
        return plan, ap.parse_args(plan["argv"])
    except (OSError, ValueError, KeyError, SystemExit):
        sys.exit("hazard_campaign: %s has no readable plan.json" % folder)


def evaluate(dataset, work, name, a, targets, vo_extra=()):
    """The navigation run with the hazard map on one dataset, then one terrain_eval per target: (trials, map
    scores at the map's resolution and as sampled, the confidence k in force)."""
    terrain = os.path.join(work, "terrain")
    os.makedirs(work, exist_ok=True)
    if not (a.reuse and os.path.exists(os.path.join(terrain, "terrain.yaml"))):
        cmd = [os.path.join(BIN, "vo_run"), "--dataset", dataset, "--config", a.config,
               "--initial-state-from-groundtruth", "--quiet", "--output", os.path.join(work, "trajectory.txt"),
               "--output-terrain", terrain] + list(vo_extra)
        if a.hazard_config:
            cmd += ["--hazard-config", a.hazard_config]
        run(cmd, os.path.join(work, "vo_run.log"))
    trials, scores, k = [], None, None
    trajectory = os.path.join(work, "trajectory.txt")
    has_pose = os.path.exists(trajectory) and any(
        line.strip() and not line.startswith("#") for line in open(trajectory))
    for (x, y) in targets:
        tag = "t%+04.0f%+04.0f" % (x, y)
        js = os.path.join(work, tag + ".json")
        cmd = [os.path.join(BIN, "terrain_eval"), "--gt", dataset, "--est", terrain, "--target-x-m", str(x),
               "--target-y-m", str(y), "--json", js]
        if has_pose:
            cmd += ["--navigation-error-from", trajectory]
        if a.confidence_k is not None:
            cmd += ["--confidence-k", str(a.confidence_k)]
        if a.max_shadow_fraction is not None:
            cmd += ["--max-shadow-fraction", str(a.max_shadow_fraction)]
        if a.max_shading_slope_deg is not None:
            cmd += ["--max-shading-slope-deg", str(a.max_shading_slope_deg)]
        if a.shading_slope_weight is not None:
            cmd += ["--shading-slope-weight", str(a.shading_slope_weight)]
        if a.shading_margin_m is not None:
            cmd += ["--shading-margin-m", str(a.shading_margin_m)]
        log = os.path.join(work, tag + ".txt")
        run(cmd, log)
        m = re.search(r"confidence k = ([0-9.]+)", open(log).read())
        k = float(m.group(1)) if m else k
        result = json.load(open(js))
        if scores is None:
            scores = {res: {key: result.get(res, {}).get(key) for key in MAP_KEYS}
                      for res in ("at_map_resolution", "full_resolution")}
            nav = result.get("navigation_frame") or {}
            for res in ("at_map_resolution", "full_resolution"):
                scores["navigation_frame_" + res] = {key: (nav.get(res) or {}).get(key) for key in MAP_KEYS}
            scores["navigation_error_m"] = result.get("navigation_error_m")
        trials.append({"dataset": name, "target_x_m": x, "target_y_m": y, "site": result.get("landing_site")})
    return trials, scores, k


def at_touchdown(site):
    """The verdict at touchdown: True (safe), False (a true hazard within the clearance), None when it cannot be
    judged: the run has no navigation error (older results), or the moved clearance reaches beyond the true
    terrain's grid (unknown cells, no hazard: the truth is unknown there, not unsafe)."""
    if site.get("safe_at_touchdown") is None:
        return None
    if site["safe_at_touchdown"]:
        return True
    return False if site["cells_hazard_at_touchdown"] > 0 else None


def touchdown_text(s):
    if s.get("safe_at_touchdown") is None:
        return "n/a"
    v = at_touchdown(s)
    if v is None:
        return "not judged (%d cells beyond the true terrain's grid)" % s["cells_unknown_at_touchdown"]
    return "safe" if v else "UNSAFE (%d hazard, %d unknown cells)" % (s["cells_hazard_at_touchdown"],
                                                                      s["cells_unknown_at_touchdown"])


def trial_row(t):
    s = t["site"]
    if s is None:
        return "| %s | (%.0f, %.0f) | none | | | no site | |" % (t["dataset"], t["target_x_m"], t["target_y_m"])
    return "| %s | (%.0f, %.0f) | (%.1f, %.1f) | %.1f deg / %.2f m | %s deg / %s m | %s | %s |" % (
        t["dataset"], t["target_x_m"], t["target_y_m"], s["x_m"], s["y_m"], s["slope_deg"], s["roughness_m"],
        "%.1f" % s["true_slope_deg"] if s["true_slope_deg"] is not None else "n/a",
        "%.2f" % s["true_roughness_m"] if s["true_roughness_m"] is not None else "n/a",
        "safe" if s["truly_safe"] else "UNSAFE (%d hazard, %d unknown cells)" % (s["cells_hazard"],
                                                                                 s["cells_unknown"]),
        touchdown_text(s))


def plan_runs(a):
    disp = {
        "terrain_seed": None, "sensor_seed": None, "dems": ["apollo15_gld100"],
        "placement_ranks": vo_campaign.parse_int_range(a.placement_ranks, "placement-ranks"),
        "sun_elevation_deg": vo_campaign.parse_range(a.sun_elevation, "sun-elevation"),
        "sun_azimuth_deg": vo_campaign.parse_range(a.sun_azimuth, "sun-azimuth"),
        "init_position_sigma_m": a.init_position_sigma_m, "init_attitude_sigma_deg": a.init_attitude_sigma_deg,
        "init_scale_sigma_percent": 0.0,
    }
    sequences = [s for s in a.sequences.split(",") if s]
    runs = []
    for k in range(a.runs):
        p = vo_campaign.draw_run_params(disp, a.seed, k)
        p["sequence"] = sequences[k % len(sequences)]
        p["id"] = "run_%03d" % k
        runs.append(p)
    return runs


def execute_run(p, a, targets):
    work = os.path.join(a.out, "runs", p["id"])
    dataset = os.path.join(work, "dataset")
    os.makedirs(work, exist_ok=True)
    t0 = time.time()
    result = {"params": p, "status": "ok", "reason": "", "trials": [], "scores": None}
    render = [os.path.join(BIN, "lunar_render"), "--sequence", p["sequence"], "--output", dataset,
              "--width", str(a.size), "--height", str(a.size), "--sensors", a.sensors,
              "--seed", str(p["terrain_seed"]), "--dem", p["dem"], "--placement-rank", str(p["placement_rank"]),
              "--sun-elevation", "%g" % p["sun_elevation_deg"], "--sun-azimuth", "%g" % p["sun_azimuth_deg"],
              "--sensor-seed", str(p["sensor_seed"]), "--start", "%g" % a.start_s,
              "--threads", str(a.render_threads), "--no-progress"]
    try:
        if a.renders_from:
            dataset = os.path.join(a.renders_from, "runs", p["id"], "dataset")
            try:
                with open(os.path.join(a.renders_from, "runs", p["id"], "result.json")) as f:
                    earlier = json.load(f)["params"]
            except (OSError, ValueError, KeyError):
                earlier = None
            if earlier != json.loads(json.dumps(p)) or not os.path.isdir(os.path.join(dataset, "images")):
                raise ToolFailed("%s: the run in %s is another draw or kept no images" % (p["id"], a.renders_from))
            # The run's folder links the dataset it used, so that the analysis scripts (site_risk_check.py,
            # shading_calibration.py, slope_weight_check.py) read this campaign folder like a rendered one.
            # A link left by an earlier --renders-from of another campaign is replaced; a rendered folder is kept.
            link = os.path.join(work, "dataset")
            if os.path.islink(link) and os.path.realpath(link) != os.path.realpath(dataset):
                os.remove(link)
            if not os.path.lexists(link):
                os.symlink(os.path.abspath(dataset), link)
        elif not (a.reuse and os.path.exists(os.path.join(work, "terrain", "terrain.yaml"))):
            run(render, os.path.join(work, "render.log"))
        vo_extra = ["--initial-error-m", ",".join("%g" % v for v in p["initial_position_error_m"]),
                    "--initial-error-deg", ",".join("%g" % v for v in p["initial_attitude_error_deg"])]
        result["trials"], result["scores"], result["confidence_k"] = evaluate(
            dataset, work, p["id"], a, targets, vo_extra)
    except ToolFailed as e:
        result["status"], result["reason"] = "failed", str(e)
    if not a.keep_images and not a.renders_from and os.path.isdir(os.path.join(dataset, "images")):
        shutil.rmtree(os.path.join(dataset, "images"), ignore_errors=True)
    result["seconds"] = round(time.time() - t0, 1)
    with open(os.path.join(work, "result.json"), "w") as f:
        json.dump(result, f, indent=1)
    return result


def planned_site(trials):
    for t in trials:
        if t["target_x_m"] == 0.0 and t["target_y_m"] == 0.0:
            return t
    return None


def stats(values):
    v = [x for x in values if x is not None]
    if not v:
        return "n/a"
    return "median %.3g, min %.3g, max %.3g (%d)" % (statistics.median(v), min(v), max(v), len(v))


def summarise(results, a, k):
    trials = [t for r in results for t in r["trials"]]
    chosen = [t for t in trials if t["site"] is not None]
    unsafe = [t for t in chosen if not t["site"]["truly_safe"]]
    distinct = {(t["dataset"], t["site"]["x_m"], t["site"]["y_m"]): t["site"]["truly_safe"] for t in chosen}
    failed = [r for r in results if r["status"] != "ok"]
    planned = [planned_site(r["trials"]) for r in results if r["status"] == "ok"]
    planned_chosen = [t for t in planned if t is not None and t["site"] is not None]
    planned_unsafe = [t for t in planned_chosen if not t["site"]["truly_safe"]]
    # At touchdown: only the sites whose run has a navigation error (None: older results, not counted).
    td_edge = [t for t in chosen if t["site"].get("safe_at_touchdown") is not None and at_touchdown(t["site"]) is None]
    td = [t for t in chosen if at_touchdown(t["site"]) is not None]
    td_unsafe = [t for t in td if not at_touchdown(t["site"])]
    td_planned = [t for t in planned_chosen if at_touchdown(t["site"]) is not None]
    td_planned_unsafe = [t for t in td_planned if not at_touchdown(t["site"])]
    td_distinct = {(t["dataset"], t["site"]["x_m"], t["site"]["y_m"]): at_touchdown(t["site"]) for t in td}
    lines = ["# Landing-site safety campaign", ""]
    lines.append("Command: `scripts/hazard_campaign.py %s`" % " ".join(sys.argv[1:]))
    lines.append("")
    lines.append("Conditions: %d runs (campaign seed %d), sequences %s in turn, %d px, %s sensors, from t = %g s "
                 "(handed-over state error sigma %g m per axis, %g deg); Sun elevation %s deg, azimuth %s deg, "
                 "placement ranks %s, terrain and sensor seeds drawn; navigation config %s; hazard config %s; "
                 "confidence k = %s; %d targets per map." % (
                     len(results), a.seed, a.sequences, a.size, a.sensors, a.start_s, a.init_position_sigma_m,
                     a.init_attitude_sigma_deg, a.sun_elevation, a.sun_azimuth, a.placement_ranks,
                     os.path.relpath(a.config, ROOT), a.hazard_config or "config/hazard.yaml's defaults",
                     "%g" % k if k is not None else "n/a", len(a.target_list)))
    overrides = ["%s %g" % (flag, v) for flag, v in (
        ("max_shadow_fraction", a.max_shadow_fraction), ("max_shading_slope_deg", a.max_shading_slope_deg),
        ("shading_slope_weight", a.shading_slope_weight), ("shading_margin_m", a.shading_margin_m))
        if v is not None]
    if overrides:
        lines[-1] += " Sites chosen and maps scored with thresholds " + ", ".join(overrides) + \
            " (terrain_eval), the rest as in the hazard config."
    lines.append("")
    lines.append("| | count |")
    lines.append("|---|---|")
    lines.append("| runs completed / failed | %d / %d |" % (len(results) - len(failed), len(failed)))
    lines.append("| site chosen for the planned target (0, 0): truly safe / UNSAFE / none | %d / %d / %d |" % (
        len(planned_chosen) - len(planned_unsafe), len(planned_unsafe), len(planned) - len(planned_chosen)))
    lines.append("| all trials: sites chosen / truly safe / UNSAFE / no site | %d / %d / %d / %d |" % (
        len(chosen), len(chosen) - len(unsafe), len(unsafe), len(trials) - len(chosen)))
    lines.append("| distinct sites chosen: truly safe / UNSAFE | %d / %d |" % (
        sum(1 for v in distinct.values() if v), sum(1 for v in distinct.values() if not v)))
    lines.append("| at touchdown (each site moved by its run's navigation error at the end): site for (0, 0) "
                 "safe / UNSAFE | %d / %d |" % (len(td_planned) - len(td_planned_unsafe), len(td_planned_unsafe)))
    lines.append("| at touchdown: all trials' sites judged / safe / UNSAFE / not judged (beyond the true terrain's "
                 "grid) | %d / %d / %d / %d |" % (len(td), len(td) - len(td_unsafe), len(td_unsafe), len(td_edge)))
    lines.append("| at touchdown: distinct sites safe / UNSAFE | %d / %d |" % (
        sum(1 for v in td_distinct.values() if v), sum(1 for v in td_distinct.values() if not v)))
    lines.append("")
    lines.append("The verdicts above the last three rows check the true terrain at each site's world coordinates. "
                 "The map and the lander's guidance both live in the navigation's frame: a lander flown to the "
                 "site by this navigation touches down on the ground the map saw there, which is displaced from "
                 "the world coordinates by the navigation's error (the handed-over state's error, which vision "
                 "cannot remove without a map of the site, plus drift). \"At touchdown\" judges that ground, "
                 "with the error at the end of the run (the low gate); drift after it is the clearance's job.")
    lines.append("")
    lines.append("By Sun elevation (low Sun: long shadows, which the map marks unknown; high Sun: rocks cast "
                 "almost none):")
    lines.append("")
    lines.append("| Sun elevation | runs | site for (0, 0): safe / UNSAFE / none | all trials: chosen / UNSAFE | "
                 "UNSAFE at touchdown |")
    lines.append("|---|---|---|---|---|")
    for lo, hi in ((0, 15), (15, 25), (25, 35), (35, 90)):
        rs = [r for r in results if r["status"] == "ok" and lo <= r["params"]["sun_elevation_deg"] < hi]
        pl = [planned_site(r["trials"]) for r in rs]
        pc = [t for t in pl if t is not None and t["site"] is not None]
        pu = [t for t in pc if not t["site"]["truly_safe"]]
        tc = [t for r in rs for t in r["trials"] if t["site"] is not None]
        tu = [t for t in tc if not t["site"]["truly_safe"]]
        tdu = [t for t in tc if at_touchdown(t["site"]) is False]
        lines.append("| %d-%d deg | %d | %d / %d / %d | %d / %d | %d |" % (
            lo, hi, len(rs), len(pc) - len(pu), len(pu), len(pl) - len(pc), len(tc), len(tu), len(tdu)))
    lines.append("")
    lines.append("Maps (one per run, the terrain model at the end of the approach):")
    lines.append("")
    for res, title in (("at_map_resolution", "at the map's resolution"), ("full_resolution", "as sampled"),
                       ("navigation_frame_at_map_resolution", "in the navigation's frame at the map's resolution"),
                       ("navigation_frame_full_resolution", "in the navigation's frame as sampled")):
        for key in MAP_KEYS:
            lines.append("- %s, %s: %s" % (key, title, stats([r["scores"].get(res, {}).get(key) for r in results
                                                               if r["scores"]])))
    horizontal = [(e[0] ** 2 + e[1] ** 2) ** 0.5 for e in (r["scores"].get("navigation_error_m") for r in results
                                                             if r["scores"]) if e]
    lines.append("- navigation error at the end of the run, horizontal (m): %s" % stats(horizontal))
    lines.append("")
    lines.append("| run | sequence | Sun el / az (deg) | placement | coverage | slope RMSE (map res.; nav. frame) | "
                 "precision / recall (map res.) | nav. error x, y, z (m) | site for (0, 0) | verdict | "
                 "at touchdown |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        p = r["params"]
        s = r["scores"]["at_map_resolution"] if r["scores"] else {}
        sn = r["scores"].get("navigation_frame_at_map_resolution", {}) if r["scores"] else {}
        e = r["scores"].get("navigation_error_m") if r["scores"] else None
        t = planned_site(r["trials"])
        site = t["site"] if t else None
        fmt = lambda v, f: (f % v) if v is not None else "n/a"  # noqa: E731
        lines.append("| %s | %s | %.1f / %.1f | %d | %s | %s; %s | %s / %s | %s | %s | %s | %s |" % (
            p["id"], p["sequence"], p["sun_elevation_deg"], p["sun_azimuth_deg"], p["placement_rank"],
            fmt(s.get("surface_coverage"), "%.3f"), fmt(s.get("slope_rmse_deg"), "%.2f"),
            fmt(sn.get("slope_rmse_deg"), "%.2f"),
            fmt(s.get("hazard_precision"), "%.2f"), fmt(s.get("hazard_recall"), "%.2f"),
            "%+.1f, %+.1f, %+.1f" % tuple(e) if e else "n/a",
            "(%.1f, %.1f)" % (site["x_m"], site["y_m"]) if site else "none",
            r["reason"] if r["status"] != "ok" else (
                "none" if not site else ("safe" if site["truly_safe"] else "UNSAFE (%d hazard cells)" %
                                         site["cells_hazard"])),
            touchdown_text(site) if site else ""))
    flagged = [t for t in chosen if not t["site"]["truly_safe"] or at_touchdown(t["site"]) is not True]
    if flagged:
        lines += ["", "Trials not safe both ways (at the world coordinates, at touchdown):", "",
                  "| dataset | target (m) | site (m) | est. slope / roughness | true slope / roughness | verdict | "
                  "at touchdown |", "|---|---|---|---|---|---|---|"] + [trial_row(t) for t in flagged]
    return "\n".join(lines) + "\n", {
        "runs": len(results), "failed": len(failed), "planned_safe": len(planned_chosen) - len(planned_unsafe),
        "planned_unsafe": len(planned_unsafe), "planned_none": len(planned) - len(planned_chosen),
        "trials": len(trials), "chosen": len(chosen), "unsafe": len(unsafe), "confidence_k": k,
        "distinct_safe": sum(1 for v in distinct.values() if v),
        "distinct_unsafe": sum(1 for v in distinct.values() if not v),
        "touchdown_judged": len(td), "touchdown_unsafe": len(td_unsafe), "touchdown_not_judged": len(td_edge),
        "touchdown_planned_unsafe": len(td_planned_unsafe),
        "touchdown_distinct_unsafe": sum(1 for v in td_distinct.values() if not v)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--datasets", nargs="+")
    src.add_argument("--runs", type=int)
    src.add_argument("--gather", action="store_true",
                     help="write the summary of the runs already in --out again (a campaign interrupted or re-read)")
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "hazard_campaign"))
    ap.add_argument("--config", default=os.path.join(ROOT, "config", "lunar_fused.yaml"))
    ap.add_argument("--hazard-config", default="", help="vo_run --hazard-config (default: config/hazard.yaml's values)")
    ap.add_argument("--confidence-k", type=float, default=None,
                    help="terrain_eval --confidence-k (default: config/hazard.yaml's sites.confidence_k)")
    ap.add_argument("--max-shading-slope-deg", type=float, default=None,
                    help="terrain_eval --max-shading-slope-deg (a large value: the shading relief is ignored)")
    ap.add_argument("--shading-slope-weight", type=float, default=None,
                    help="terrain_eval --shading-slope-weight (0: the slope limit without the shading relief)")
    ap.add_argument("--shading-margin-m", type=float, default=None,
                    help="terrain_eval --shading-margin-m (0: only the cells whose own shading exceeds the limit)")
    ap.add_argument("--max-shadow-fraction", type=float, default=None,
                    help="terrain_eval --max-shadow-fraction (1: cells seen in shadow are not unknown)")
    ap.add_argument("--targets", default="", help='"x,y;x,y;..." in metres (default: a 3 x 3 grid 64 m apart)')
    ap.add_argument("--reuse", action="store_true", help="keep a dataset's existing terrain map")
    ap.add_argument("--json", default="")
    ap.add_argument("--write-docs", default="", help="copy summary.md and summary.json there (--runs)")
    g = ap.add_argument_group("Monte Carlo campaign (--runs)")
    g.add_argument("--seed", type=int, default=1)
    g.add_argument("--sequences", default="approach_down,approach_30deg,approach_nozzle")
    g.add_argument("--size", type=int, default=1024)
    g.add_argument("--sensors", default="flight")
    g.add_argument("--start-s", type=float, default=40.0)
    g.add_argument("--sun-elevation", default=vo_campaign.DEFAULTS["sun_elevation"])
    g.add_argument("--sun-azimuth", default=vo_campaign.DEFAULTS["sun_azimuth"])
    g.add_argument("--placement-ranks", default=vo_campaign.DEFAULTS["placement_ranks"])
    g.add_argument("--init-position-sigma-m", type=float, default=1.0)
    g.add_argument("--init-attitude-sigma-deg", type=float, default=vo_campaign.DEFAULTS["init_attitude_sigma_deg"])
    g.add_argument("--jobs", type=int, default=max(1, len(os.sched_getaffinity(0))))
    g.add_argument("--render-threads", type=int, default=1)
    g.add_argument("--keep-images", action="store_true", help="keep each run's images (about 220 MB at 1024 px)")
    g.add_argument("--renders-from", default="", metavar="CAMPAIGN",
                   help="no rendering: the datasets of this earlier campaign of the same draws (run with --keep-images)")
    a = ap.parse_args()
    if a.renders_from and a.runs:
        # The renders must be of the same size, sensors and start as this campaign would render.
        _, earlier = read_plan(ap, a.renders_from)
        for key in ("size", "sensors", "start_s"):
            if getattr(earlier, key) != getattr(a, key):
                sys.exit("hazard_campaign: --renders-from %s was rendered with --%s %s, not %s" % (
                    a.renders_from, key.replace("_", "-"), getattr(earlier, key), getattr(a, key)))
    a.target_list = DEFAULT_TARGETS
    if a.targets:
        a.target_list = [tuple(float(v) for v in t.split(",")) for t in a.targets.split(";") if t.strip()]
    os.makedirs(a.out, exist_ok=True)
    print("| dataset | target (m) | site (m) | est. slope / roughness | true slope / roughness | verdict | "
          "at touchdown |")
    print("|---|---|---|---|---|---|---|")
    k = None
    if a.datasets:
        results = []
        for dataset in a.datasets:
            name = os.path.basename(os.path.normpath(dataset))
            try:
                trials, scores, k = evaluate(dataset, os.path.join(a.out, name), name, a, a.target_list)
            except ToolFailed as e:
                sys.exit("hazard_campaign: " + str(e))
            for t in trials:
                say(trial_row(t))
            results.append({"params": {"id": name}, "status": "ok", "trials": trials, "scores": scores})
        trials = [t for r in results for t in r["trials"]]
        chosen = [t for t in trials if t["site"] is not None]
        unsafe = [t for t in chosen if not t["site"]["truly_safe"]]
        print("\nhazard_campaign: %d trials on %d datasets (k = %s): %d sites chosen, %d truly safe, %d UNSAFE "
              "(on %d of %d datasets)" % (len(trials), len(a.datasets), "%g" % k if k is not None else "n/a",
                                           len(chosen), len(chosen) - len(unsafe), len(unsafe),
                                           len({t["dataset"] for t in unsafe}), len(a.datasets)))
        if a.json:
            with open(a.json, "w") as f:
                json.dump({"confidence_k": k, "trials": trials}, f, indent=1)
        return 1 if unsafe else 0

    if a.gather:
        plan, campaign = read_plan(ap, a.out)
        results = []
        for p in plan["runs"]:
            path = os.path.join(a.out, "runs", p["id"], "result.json")
            if os.path.exists(path):
                results.append(json.load(open(path)))
        k = next((r.get("confidence_k") for r in results if r.get("confidence_k") is not None), None)
        # The conditions are those of the campaign's own command line.
        for key in ("seed", "sequences", "size", "sensors", "start_s", "init_position_sigma_m",
                    "init_attitude_sigma_deg", "sun_elevation", "sun_azimuth", "placement_ranks", "config",
                    "hazard_config"):
            setattr(a, key, getattr(campaign, key))
        sys.argv = [sys.argv[0]] + plan["argv"]
    else:
        runs = plan_runs(a)
        with open(os.path.join(a.out, "plan.json"), "w") as f:
            json.dump({"argv": sys.argv[1:], "runs": runs}, f, indent=1)
        results = run_all(runs, a)
        k = next((r.get("confidence_k") for r in results if r.get("confidence_k") is not None), None)
    text, summary = summarise(results, a, k)
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write(text)
    with open(os.path.join(a.out, "summary.json"), "w") as f:
        json.dump({"summary": summary, "runs": results}, f, indent=1)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"confidence_k": k, "trials": [t for r in results for t in r["trials"]]}, f, indent=1)
    if a.write_docs:
        os.makedirs(a.write_docs, exist_ok=True)
        shutil.copy(os.path.join(a.out, "summary.md"), a.write_docs)
        shutil.copy(os.path.join(a.out, "summary.json"), a.write_docs)
    print()
    print(text)
    return 1 if summary["unsafe"] or summary["failed"] else 0


def run_all(runs, a):
    t0 = time.time()
    results = [None] * len(runs)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        futures = {pool.submit(execute_run, p, a, a.target_list): i for i, p in enumerate(runs)}
        done = 0
        for fut in concurrent.futures.as_completed(futures):
            i = futures[fut]
            r = fut.result()
            results[i] = r
            done += 1
            t = planned_site(r["trials"])
            verdict = r["reason"] if r["status"] != "ok" else (
                "no site for (0, 0)" if not t or not t["site"] else
                ("site for (0, 0) safe" if t["site"]["truly_safe"] else "site for (0, 0) UNSAFE"))
            n_unsafe = sum(1 for t in r["trials"] if t["site"] and not t["site"]["truly_safe"])
            say("[%d/%d] %s %s sun %.1f deg: %s; %d unsafe of %d trials (%.0f s, elapsed %.0f min)" % (
                done, len(runs), r["params"]["id"], r["params"]["sequence"], r["params"]["sun_elevation_deg"],
                verdict, n_unsafe, len(r["trials"]), r["seconds"], (time.time() - t0) / 60.0))
    return results


if __name__ == "__main__":
    sys.exit(main())
