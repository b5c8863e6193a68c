#!/usr/bin/env bash
# The main job, on a fresh Debian 12 machine (as root): installs every dependency, builds, then runs the Lunar demo
# through ROS, headless (no terminal and no display needed):
#   1. renders a Lunar descent sequence (approach_down, 512x512, first 20 s, flight-like sensors; cached when
#      unchanged),
#   2. streams it through the VO nodelet with `roslaunch planetary_vo lunar_demo.launch` (player -> VO; the
#      trajectory recorders write vo/pose and ground_truth/pose; the launch ends by itself when the VO has
#      processed the last image),
#   3. scores the trajectory against the dataset's ground truth (vo_eval: Sim(3) ATE, RPE, attitude drift, plots),
#   4. runs the two-view geometry benchmark (thesis figures 3.6-3.13 as a table),
#   5. (DEMO_RVIZ=1 only) replays it once more with rviz under xvfb and saves a screenshot.
# Results go to output/demo/. Options through the environment:
#   DEMO_SEQUENCE (approach_down), DEMO_SIZE (512), DEMO_DURATION (20 seconds; 0 = whole sequence),
#   DEMO_SENSORS (flight; ideal = the perfect sensors of renderer 1.2),
#   DEMO_RVIZ (0; 1 = also the rviz screenshot, needs the GUI packages: rviz xvfb xauth imagemagick),
#   DEMO_ROS_PORT (a free port; the ROS master of the demo, so that it never joins another running master).
set -euo pipefail
source "$(dirname "$0")/env.sh"
"$PLANETARY_VO_ROOT/scripts/install_deps.sh"
planetary_vo_build
# The package for roslaunch (devel space); catkin's setup scripts read unset variables.
set +u
# shellcheck disable=SC1091
source "$PLANETARY_VO_BUILD/devel/setup.bash"
set -u

BIN="$PLANETARY_VO_BUILD/devel/lib/planetary_vo"
OUT="$PLANETARY_VO_OUTPUT/demo"
SEQUENCE="${DEMO_SEQUENCE:-approach_down}"
SIZE="${DEMO_SIZE:-512}"
DURATION="${DEMO_DURATION:-20}"
SENSORS="${DEMO_SENSORS:-flight}"
RVIZ="${DEMO_RVIZ:-0}"
DATASET="$PLANETARY_VO_OUTPUT/sequences/${SEQUENCE}_${SIZE}px_${DURATION}s_${SENSORS}"
mkdir -p "$OUT"

# A master of our own on a free port: roslaunch starts it and stops it again.
PORT="${DEMO_ROS_PORT:-$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')}"
export ROS_MASTER_URI="http://localhost:$PORT"

echo "== 1/4 rendering $SEQUENCE (${SIZE}x${SIZE}, ${DURATION} s, $SENSORS sensors) into $DATASET"
render_args=(--sequence "$SEQUENCE" --output "$DATASET" --width "$SIZE" --height "$SIZE" --sensors "$SENSORS")
[ "$DURATION" != 0 ] && render_args+=(--duration "$DURATION")
"$BIN/lunar_render" "${render_args[@]}"

# Images in the dataset and its span in seconds (times.txt: one stamp per image, '#' comments).
NUM_IMAGES="$(grep -vc '^#' "$DATASET/times.txt")"
SPAN="$(awk '!/^#/ { if (n++ == 0) first = $1; last = $1 } END { printf "%.1f", last - first }' "$DATASET/times.txt")"
SPAN_S="${SPAN%.*}"

echo "== 2/4 running the VO through ROS: roslaunch planetary_vo lunar_demo.launch (real time, ${SPAN} s, headless)"
rm -f "$OUT/trajectory.txt" "$OUT/groundtruth.txt"
# The player leaves once the VO has reported on the last image and, being required, ends the launch (and the
# master it started); the timeout only guards against a hang (startup + the sequence at real time + slack).
timeout --signal=INT --kill-after=20 "$((SPAN_S * 3 + 120))" \
  roslaunch -p "$PORT" planetary_vo lunar_demo.launch dataset:="$DATASET" rviz:=false exit_when_done:=true \
  est_output:="$OUT/trajectory.txt" gt_output:="$OUT/groundtruth.txt" </dev/null 2>&1 | tee "$OUT/roslaunch.txt"
POSES="$(grep -vc '^#' "$OUT/trajectory.txt" || true)"
if [ "$POSES" -lt 3 ]; then
  echo "demo: the VO wrote only $POSES poses to $OUT/trajectory.txt (see $OUT/roslaunch.txt)" >&2
  exit 1
fi
echo "vo/pose recorded for $POSES of $NUM_IMAGES images"

echo "== 3/4 scoring the trajectory against ground truth (Sim(3) alignment)"
"$BIN/vo_eval" --gt "$DATASET" --est "$OUT/trajectory.txt" --align sim3 \
  --json "$OUT/accuracy.json" --plot "$OUT/plots" | tee "$OUT/accuracy.txt"

echo "== 4/4 two-view geometry benchmark"
"$BIN/geometry_benchmark" --markdown > "$OUT/geometry_benchmark.md"

if [ "$RVIZ" = 1 ]; then
  echo "== extra: rviz under xvfb (the same launch with rviz:=true), screenshot when the player has played everything"
  rm -f "$OUT/rviz_groundtruth.txt" "$OUT/rviz.png"
  # Inside xvfb-run: the launch in the background; once the ground-truth recorder has every image (the player is
  # done) and the aligned path has been drawn for a moment, grab the screen, then stop the launch (SIGINT).
  export DATASET PORT OUT NUM_IMAGES
  timeout --signal=INT --kill-after=20 "$((SPAN_S * 3 + 180))" xvfb-run -a -s "-screen 0 1280x800x24" bash -c '
    set -u
    roslaunch -p "$PORT" planetary_vo lunar_demo.launch dataset:="$DATASET" rviz:=true \
      gt_output:="$OUT/rviz_groundtruth.txt" </dev/null >"$OUT/roslaunch_rviz.txt" 2>&1 &
    launch=$!
    while kill -0 $launch 2>/dev/null && [ "$(grep -vc "^#" "$OUT/rviz_groundtruth.txt" 2>/dev/null || true)" != "$NUM_IMAGES" ]; do
      sleep 1  # polling period of the condition (the player has published every image)
    done
    # Not a synchronisation: rviz draws at a few frames per second under llvmpipe; give it time to draw the last
    # poses before the screen is grabbed.
    sleep 3
    import -window root "$OUT/rviz_full.png" && /usr/bin/convert "$OUT/rviz_full.png" -resize 1024x "$OUT/rviz.png"
    rm -f "$OUT/rviz_full.png"
    kill -INT $launch
    wait $launch || true
    [ -s "$OUT/rviz.png" ]
  ' || echo "demo: the rviz screenshot failed (see $OUT/roslaunch_rviz.txt)" >&2
fi

RVIZ_LINE=""
[ -s "$OUT/rviz.png" ] && [ "$RVIZ" = 1 ] &&
  RVIZ_LINE="  rviz.png               rviz under xvfb: ground truth, aligned estimate, map points, tracking image
"
# Headline numbers from the accuracy report.
read -r ATE_PCT ATE_M DRIFT_DEG ASSOC NUM_GT < <(/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
print("%.3f %.3f %.3f %d %d" % (d["ate_rmse_percent_of_path"], d["ate_m"]["rmse"], d["attitude_drift_deg"]["rmse"],
                                d["num_associated"], d["num_ground_truth"]))' "$OUT/accuracy.json")

cat <<MSG

Demo finished. Results in $OUT:
  trajectory.txt         estimated camera poses (vo/pose as TUM lines, dataset times, one per processed frame)
  groundtruth.txt        ground_truth/pose as published by the player (TUM)
  accuracy.txt / .json   accuracy report against the dataset's ground truth (Sim(3) alignment)
  plots/                 trajectory, downrange/crossrange/altitude and attitude against ground truth
  roslaunch.txt          the ROS run (player, VO nodelet, overlay with its running ATE, recorders)
  geometry_benchmark.md  two-view geometry accuracy and timing table
${RVIZ_LINE}Rendered sequence: $DATASET

Headline ($SEQUENCE, ${SIZE}x${SIZE}, $SENSORS sensors, ${SPAN} s through ROS at real time):
  ATE (Sim(3)) RMSE      $ATE_PCT % of the path ($ATE_M m)
  attitude drift RMS     $DRIFT_DEG deg
  frames with a pose     $ASSOC of $NUM_GT
MSG
