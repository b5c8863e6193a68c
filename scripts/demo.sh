#!/usr/bin/env bash
# The main job, on a fresh Debian 12 machine (as root): installs every dependency, builds, then runs the Lunar demo
# through ROS, headless (no terminal and no display needed):
#   1. renders a Lunar descent sequence (approach_30deg: the final approach to the landing site with the camera
#      30 deg forward, 1024x1024, the whole 55 s, flight-like sensors; about 20 min on 2 cores, cached when
#      unchanged),
#   2. runs the autonomous GNC chain on it with `roslaunch planetary_vo agnc.launch` (player -> VO navigation with
#      camera + IMU + altimeter, started from the state guidance hands over -> hazard nodelet in the same manager;
#      recorders write vo/pose, ground_truth/pose and the latest hazard map and landing sites; the launch ends by
#      itself once the hazard map includes the last image),
#   3. scores the trajectory against the dataset's ground truth (vo_eval: Sim(3) ATE, RPE, attitude drift, plots),
#      and the hazard map and the chosen landing site against the true terrain (terrain_eval),
#   4. runs the two-view geometry benchmark (thesis figures 3.6-3.13 as a table),
#   5. (DEMO_RVIZ=1 only) replays it once more with rviz under xvfb and saves a screenshot.
# Results go to output/demo/. Options through the environment:
#   DEMO_SEQUENCE (approach_30deg), DEMO_SIZE (1024), DEMO_DURATION (0 = whole sequence; else seconds),
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
SEQUENCE="${DEMO_SEQUENCE:-approach_30deg}"
SIZE="${DEMO_SIZE:-1024}"
DURATION="${DEMO_DURATION:-0}"
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

# The Sun's elevation and azimuth the sequence was rendered with: the ephemeris a mission has for its landing time,
# which the hazard map's shading relief needs (terrain/shading_relief.h).
SUN_ELEVATION_DEG="$(awk '/^sun:/ { s = 1 } s && /elevation_deg:/ { print $2; exit }' "$DATASET/sequence.yaml")"
SUN_AZIMUTH_DEG="$(awk '/^sun:/ { s = 1 } s && /azimuth_deg:/ { print $2; exit }' "$DATASET/sequence.yaml")"

echo "== 2/4 running the AGNC chain through ROS: roslaunch planetary_vo agnc.launch (real time, ${SPAN} s, headless)"
rm -rf "$OUT/trajectory.txt" "$OUT/groundtruth.txt" "$OUT/hazard"
# The player leaves once the hazard map recorded in $OUT/hazard includes the last image and, being required, ends
# the launch (and the master it started); the timeout only guards against a hang (startup + the sequence at real
# time + slack).
timeout --signal=INT --kill-after=20 "$((SPAN_S * 3 + 120))" \
  roslaunch -p "$PORT" planetary_vo agnc.launch dataset:="$DATASET" rviz:=false exit_when_done:=true \
  est_output:="$OUT/trajectory.txt" gt_output:="$OUT/groundtruth.txt" hazard_output:="$OUT/hazard" \
  sun_elevation_deg:="${SUN_ELEVATION_DEG:-0}" sun_azimuth_deg:="${SUN_AZIMUTH_DEG:--1}" </dev/null 2>&1 | tee "$OUT/roslaunch.txt"
POSES="$(grep -vc '^#' "$OUT/trajectory.txt" || true)"
if [ "$POSES" -lt 3 ]; then
  echo "demo: the VO wrote only $POSES poses to $OUT/trajectory.txt (see $OUT/roslaunch.txt)" >&2
  exit 1
fi
echo "vo/pose recorded for $POSES of $NUM_IMAGES images"

echo "== 3/4 scoring the trajectory against ground truth (Sim(3) alignment) and the hazard map against the true terrain"
"$BIN/vo_eval" --gt "$DATASET" --est "$OUT/trajectory.txt" --align sim3 \
  --json "$OUT/accuracy.json" --plot "$OUT/plots" | tee "$OUT/accuracy.txt"
if [ ! -s "$OUT/hazard/terrain.yaml" ] || [ ! -s "$OUT/hazard/landing_sites.yaml" ]; then
  echo "demo: the hazard nodelet's map was not recorded in $OUT/hazard (see $OUT/roslaunch.txt)" >&2
  exit 1
fi
"$BIN/terrain_eval" --gt "$DATASET" --est "$OUT/hazard" --json "$OUT/hazard_accuracy.json" | tee "$OUT/hazard_accuracy.txt"

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
    roslaunch -p "$PORT" planetary_vo agnc.launch dataset:="$DATASET" rviz:=true \
      gt_output:="$OUT/rviz_groundtruth.txt" </dev/null >"$OUT/roslaunch_rviz.txt" 2>&1 &
    launch=$!
    while kill -0 $launch 2>/dev/null && [ "$(grep -vc "^#" "$OUT/rviz_groundtruth.txt" 2>/dev/null || true)" != "$NUM_IMAGES" ]; do
      sleep 1  # polling period of the condition (the player has published every image)
    done
    # Not a synchronisation: rviz draws at a few frames per second under llvmpipe, and the hazard nodelet
    # publishes its map every 2 s; give both time to draw the last state before the screen is grabbed.
    sleep 6
    import -window root "$OUT/rviz_full.png" && /usr/bin/convert "$OUT/rviz_full.png" -resize 1024x "$OUT/rviz.png"
    rm -f "$OUT/rviz_full.png"
    kill -INT $launch
    wait $launch || true
    [ -s "$OUT/rviz.png" ]
  ' || echo "demo: the rviz screenshot failed (see $OUT/roslaunch_rviz.txt)" >&2
fi

RVIZ_LINE=""
[ -s "$OUT/rviz.png" ] && [ "$RVIZ" = 1 ] &&
  RVIZ_LINE="  rviz.png               rviz under xvfb: true terrain, hazard map, estimated elevation, landing sites,
                         trajectory and ground truth, tracking image
"
# Headline numbers from the accuracy report.
read -r ATE_PCT ATE_M DRIFT_DEG ASSOC NUM_GT < <(/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
print("%.3f %.3f %.3f %d %d" % (d["ate_rmse_percent_of_path"], d["ate_m"]["rmse"], d["attitude_drift_deg"]["rmse"],
                                d["num_associated"], d["num_ground_truth"]))' "$OUT/accuracy.json")
# The landing site the hazard nodelet chose, checked against the true terrain (terrain_eval's JSON).
SITE_LINES="$(/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
m = d["at_map_resolution"] if d.get("at_map_resolution") else d["full_resolution"]
s = d.get("landing_site")
f = lambda v, p: "n/a" if v is None else ("%." + str(p) + "f") % v
print("  hazard map             slope RMSE %s deg at the map resolution (%s as sampled), hazard precision %s / recall %s,"
      % (f(m["slope_rmse_deg"], 2), f(d["full_resolution"]["slope_rmse_deg"], 2), f(m["hazard_precision"], 2),
         f(m["hazard_recall"], 2)))
print("                         coverage of the 256 m landing area %s %%" % f(100 * d["full_resolution"]["surface_coverage"], 1))
if s is None:
    print("  landing site           none chosen (see hazard_accuracy.txt)")
else:
    print("  landing site           (%s, %s) m: estimated slope %s deg, roughness %s m" % (f(s["x_m"], 1), f(s["y_m"], 1),
          f(s["slope_deg"], 1), f(s["roughness_m"], 2)))
    print("                         true slope %s deg, true roughness %s m: %s (%d hazardous cells within the clearance)"
          % (f(s["true_slope_deg"], 1), f(s["true_roughness_m"], 2), "truly SAFE" if s["truly_safe"] else "NOT SAFE",
             s["cells_hazard"]))
' "$OUT/hazard_accuracy.json")"

cat <<MSG

Demo finished. Results in $OUT:
  trajectory.txt         estimated camera poses (vo/pose as TUM lines, dataset times, one per processed frame)
  groundtruth.txt        ground_truth/pose as published by the player (TUM)
  accuracy.txt / .json   accuracy report against the dataset's ground truth (Sim(3) alignment)
  plots/                 trajectory, downrange/crossrange/altitude and attitude against ground truth
  roslaunch.txt          the ROS run (player, VO and hazard nodelets, recorders)
  hazard/                the hazard map (terrain.yaml + layers) and landing_sites.yaml as published
  hazard_accuracy.txt    the hazard map and the chosen site against the true terrain (terrain_eval)
  geometry_benchmark.md  two-view geometry accuracy and timing table
${RVIZ_LINE}Rendered sequence: $DATASET

Headline ($SEQUENCE, ${SIZE}x${SIZE}, $SENSORS sensors, ${SPAN} s through ROS at real time, camera + IMU +
altimeter from the handed-over state):
  ATE (Sim(3)) RMSE      $ATE_PCT % of the path ($ATE_M m)
  attitude drift RMS     $DRIFT_DEG deg
  frames with a pose     $ASSOC of $NUM_GT
$SITE_LINES
MSG
