#!/usr/bin/env bash
# The main job, on a fresh Debian 12 machine (as root): installs every dependency, builds, then runs the Lunar demo:
#   1. renders a Lunar descent sequence (approach_down, 512x512, first 20 s; cached when unchanged),
#   2. replays it through the VO (vo_run, default configuration),
#   3. writes the trajectory, the accuracy report (Sim(3) ATE, RPE, rotation error) and plots,
#   4. runs the two-view geometry benchmark (thesis figures 3.6-3.13 as a table).
# Results go to output/demo/. Options through the environment:
#   DEMO_SEQUENCE (approach_down), DEMO_SIZE (512), DEMO_DURATION (20 seconds; 0 = whole sequence)
set -euo pipefail
source "$(dirname "$0")/env.sh"
"$PLANETARY_VO_ROOT/scripts/install_deps.sh"
planetary_vo_build

BIN="$PLANETARY_VO_BUILD/devel/lib/planetary_vo"
OUT="$PLANETARY_VO_OUTPUT/demo"
SEQUENCE="${DEMO_SEQUENCE:-approach_down}"
SIZE="${DEMO_SIZE:-512}"
DURATION="${DEMO_DURATION:-20}"
DATASET="$PLANETARY_VO_OUTPUT/sequences/${SEQUENCE}_${SIZE}px_${DURATION}s"
mkdir -p "$OUT"

echo "== 1/4 rendering $SEQUENCE (${SIZE}x${SIZE}, ${DURATION} s) into $DATASET"
render_args=(--sequence "$SEQUENCE" --output "$DATASET" --width "$SIZE" --height "$SIZE")
[ "$DURATION" != 0 ] && render_args+=(--duration "$DURATION")
"$BIN/lunar_render" "${render_args[@]}"

echo "== 2/4 running the VO (config/default.yaml)"
"$BIN/vo_run" --dataset "$DATASET" --config "$PLANETARY_VO_ROOT/config/default.yaml" \
  --output "$OUT/trajectory.txt" | tee "$OUT/vo_run.txt"

echo "== 3/4 scoring the trajectory against ground truth (Sim(3) alignment)"
"$BIN/vo_eval" --gt "$DATASET/groundtruth.txt" --est "$OUT/trajectory.txt" --align sim3 \
  --json "$OUT/accuracy.json" --plot "$OUT/plots" | tee "$OUT/accuracy.txt"

echo "== 4/4 two-view geometry benchmark"
"$BIN/geometry_benchmark" --markdown > "$OUT/geometry_benchmark.md"

cat <<MSG

Demo finished. Results in $OUT:
  trajectory.txt         estimated camera poses (TUM format, one line per processed frame)
  accuracy.txt / .json   accuracy report against ground truth
  plots/                 trajectory, downrange/crossrange/altitude and attitude against ground truth
  vo_run.txt             per-stage timing (median, p99) and peak memory
  geometry_benchmark.md  two-view geometry accuracy and timing table
Rendered sequence: $DATASET
MSG
