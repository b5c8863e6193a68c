#!/usr/bin/python3
"""Landing-site safety campaign (issue 11): is every site the hazard map chooses truly safe?

For each rendered dataset (with its groundtruth_terrain grids): one fused navigation run with the hazard map
(`vo_run --config config/lunar_fused.yaml --initial-state-from-groundtruth --output-terrain DIR`, the map at the
end of the sequence), then, for each target on a grid over the landing area, `terrain_eval` chooses the best site
within reach of that target on the estimated map (findLandingSites with the map's own sigmas and the given
confidence k) and checks it against the true terrain (every true cell within the clearance known and safe).

Each (dataset, target) pair is one trial. Trials on one dataset share its map, so they are not independent: the
summary gives both counts. Prints a table and a summary line; --json writes every trial.

  scripts/hazard_campaign.py --datasets DIR [DIR ...] [--out output/hazard_campaign] [--confidence-k 2]
                             [--targets "x,y;x,y;..."] [--hazard-config FILE] [--max-shadow-fraction F] [--reuse]
                             [--json FILE]
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.environ.get("PLANETARY_VO_BUILD", os.path.join(ROOT, "build"))
BIN = os.path.join(BUILD, "devel", "lib", "planetary_vo")
# Targets 64 m apart over the 256 m landing area (the default search radius is 50 m): nine per dataset.
DEFAULT_TARGETS = [(x, y) for y in (-64.0, 0.0, 64.0) for x in (-64.0, 0.0, 64.0)]


def run(cmd, log):
    with open(log, "w") as out:
        rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT)
    if rc != 0:
        sys.exit("hazard_campaign: %s failed (rc %d), see %s" % (os.path.basename(cmd[0]), rc, log))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--datasets", nargs="+", required=True)
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "hazard_campaign"))
    ap.add_argument("--config", default=os.path.join(ROOT, "config", "lunar_fused.yaml"))
    ap.add_argument("--hazard-config", default="", help="vo_run --hazard-config (default: config/hazard.yaml's values)")
    ap.add_argument("--confidence-k", type=float, default=2.0)
    ap.add_argument("--max-shadow-fraction", type=float, default=None,
                    help="terrain_eval --max-shadow-fraction (1: cells seen in shadow are not hazards)")
    ap.add_argument("--targets", default="", help='"x,y;x,y;..." in metres (default: a 3 x 3 grid 64 m apart)')
    ap.add_argument("--reuse", action="store_true", help="keep a dataset's existing terrain map")
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    targets = DEFAULT_TARGETS
    if a.targets:
        targets = [tuple(float(v) for v in t.split(",")) for t in a.targets.split(";") if t.strip()]
    os.makedirs(a.out, exist_ok=True)
    trials = []
    print("| dataset | target (m) | site (m) | est. slope / roughness | true slope / roughness | verdict |")
    print("|---|---|---|---|---|---|")
    for dataset in a.datasets:
        name = os.path.basename(os.path.normpath(dataset))
        work = os.path.join(a.out, name)
        terrain = os.path.join(work, "terrain")
        os.makedirs(work, exist_ok=True)
        if not (a.reuse and os.path.exists(os.path.join(terrain, "terrain.yaml"))):
            cmd = [os.path.join(BIN, "vo_run"), "--dataset", dataset, "--config", a.config,
                   "--initial-state-from-groundtruth", "--quiet", "--output", os.path.join(work, "trajectory.txt"),
                   "--output-terrain", terrain]
            if a.hazard_config:
                cmd += ["--hazard-config", a.hazard_config]
            run(cmd, os.path.join(work, "vo_run.log"))
        for (x, y) in targets:
            tag = "t%+04.0f%+04.0f" % (x, y)
            js = os.path.join(work, tag + ".json")
            run([os.path.join(BIN, "terrain_eval"), "--gt", dataset, "--est", terrain, "--target-x-m", str(x),
                 "--target-y-m", str(y), "--confidence-k", str(a.confidence_k), "--json", js]
                + (["--max-shadow-fraction", str(a.max_shadow_fraction)] if a.max_shadow_fraction is not None else []),
                os.path.join(work, tag + ".txt"))
            site = json.load(open(js)).get("landing_site")
            trial = {"dataset": name, "target_x_m": x, "target_y_m": y, "site": site}
            trials.append(trial)
            if site is None:
                print("| %s | (%.0f, %.0f) | none | | | no site |" % (name, x, y))
            else:
                print("| %s | (%.0f, %.0f) | (%.1f, %.1f) | %.1f deg / %.2f m | %s deg / %s m | %s |" % (
                    name, x, y, site["x_m"], site["y_m"], site["slope_deg"], site["roughness_m"],
                    "%.1f" % site["true_slope_deg"] if site["true_slope_deg"] is not None else "n/a",
                    "%.2f" % site["true_roughness_m"] if site["true_roughness_m"] is not None else "n/a",
                    "safe" if site["truly_safe"] else "UNSAFE (%d hazard, %d unknown cells)" % (
                        site["cells_hazard"], site["cells_unknown"])))
            sys.stdout.flush()
    chosen = [t for t in trials if t["site"] is not None]
    unsafe = [t for t in chosen if not t["site"]["truly_safe"]]
    datasets_unsafe = sorted({t["dataset"] for t in unsafe})
    print("\nhazard_campaign: %d trials on %d datasets (k = %.1f): %d sites chosen, %d truly safe, %d UNSAFE "
          "(on %d of %d datasets)" % (len(trials), len(a.datasets), a.confidence_k, len(chosen),
                                       len(chosen) - len(unsafe), len(unsafe), len(datasets_unsafe),
                                       len(a.datasets)))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"confidence_k": a.confidence_k, "trials": trials}, f, indent=1)
    return 1 if unsafe else 0


if __name__ == "__main__":
    sys.exit(main())
