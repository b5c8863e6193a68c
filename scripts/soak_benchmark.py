#!/usr/bin/python3
"""Soak benchmark of the VO nodelet (issue 12; a benchmark that prints numbers, not a test).

Starts launch/soak.launch on its own master (the player replays a dataset in a loop at --rate times real time
into the VO nodelet's manager), subscribes like rviz to every output of the VO (vo/pose, vo/odometry,
vo/path, vo/map_points, vo/tracking_image, vo/map_events, vo/status, nav/odometry, tf; the heavy ones as raw
messages, never decoded), and for --minutes:
  - samples the resident memory (VmRSS) of the nodelet manager every --sample-s seconds,
  - counts the images the player published (one ground_truth/pose per image) that got no vo/status (dropped:
    the VO fell behind and its input queue overflowed, or a message was lost),
  - tells the two apart by the VO's own count of images received (VoStatus.num_images), and records per loop
    the VO's lag (status arrival minus ground-truth pose arrival here), the pipeline's time, every recovery and
    scale-source change with its status message, and the machine's busy and steal time,
  - scores every complete loop on its own: Sim(3) ATE (vo_eval) of the poses the status calls TRACKING or
    RECOVERED against that loop's ground truth, and the Sim(3) scale (metres per VO unit) of each loop, whose
    loop-to-loop ratio shows whether the vision-only scale drifts across the losses.
Ctrl-C stops the graph and scores the loops completed so far.
Each loop starts with the camera jumping back to the start of the descent: a tracking loss the VO recovers from
without a reset, so the loops also test that nothing accumulates across losses (memory, scale).

Prints memory at the start (after the first loop) and the end, the growth and its trend, frames published /
dropped, the ATE of the first loop, the median and the worst, and how many loops are within 2x of the first;
writes soak.json (every loop and memory sample) into --out.

Usage (after scripts/demo.sh or planetary_vo_build made build/, and a 512 px render exists):
  source scripts/env.sh && source build/devel/setup.bash
  /usr/bin/python3 scripts/soak_benchmark.py --dataset output/benchmark/sequences/approach_down_512px_ideal \
      --rate 10 --minutes 60 --out output/soak
"""
import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time


def read_ground_truth_positions(dataset):
    """Positions of groundtruth.txt (TUM: t x y z qx qy qz qw), in image order."""
    out = []
    with open(os.path.join(dataset, "groundtruth.txt")) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                v = line.split()
                out.append((float(v[1]), float(v[2]), float(v[3])))
    return out


def rss_kb(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def median_and_max(values):
    """[median, max] of a list of numbers rounded to 0.01, or None when it is empty."""
    v = sorted(values)
    return [round(v[len(v) // 2], 2), round(v[-1], 2)] if v else None


def cpu_times():
    """Machine-wide jiffies from /proc/stat: (busy, steal, total). Steal is time the hypervisor gave to
    other guests: a soak on a VM can fall behind because of its neighbours, not of the VO."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + (v[4] if len(v) > 4 else 0)
    steal = v[7] if len(v) > 7 else 0
    total = sum(v[:8])
    return total - idle - steal, steal, total


def find_manager_pid(name, timeout_s=60.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        out = subprocess.run(["pgrep", "-f", "__name:=%s" % name], capture_output=True, text=True).stdout.split()
        if out:
            return int(out[0])
        time.sleep(0.5)
    return None


def compact(p):
    """A PoseStamped as a tuple of floats (x y z qx qy qz qw): an hour at 10x keeps about 720,000 poses, as
    message objects several million objects for Python's garbage collector to scan; tuples of floats are not
    scanned. (It did not change the lag the soak measures: that was the bundle adjustment, see
    docs/ros_interface.md.)"""
    o = p.pose.orientation
    x = p.pose.position
    return (x.x, x.y, x.z, o.x, o.y, o.z, o.w)


def tum_line(t, p):
    # 17 significant digits: after many losses a vision-only map moves by 1e-9 units per frame, below the 9
    # decimals of a usual TUM file (the first soak's loops 10+ were scored on quantised positions).
    return "%.9f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n" % ((t,) + p)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dataset", required=True, help="dataset folder (planetary_vo format, with groundtruth.txt)")
    parser.add_argument("--rate", type=float, default=10.0, help="replay speed factor (default 10)")
    parser.add_argument("--minutes", type=float, default=60.0, help="soak duration in wall-clock minutes")
    parser.add_argument("--config", default="", help="VO configuration YAML (default: config/default.yaml)")
    parser.add_argument("--queue-size", type=int, default=100, help="VO and player queue size (default 100)")
    parser.add_argument("--sample-s", type=float, default=5.0, help="memory sampling period [s]")
    parser.add_argument("--port", type=int, default=11391, help="port of the benchmark's own ROS master")
    parser.add_argument("--out", default="output/soak", help="folder for soak.json and the per-loop files")
    parser.add_argument("--vo-eval", default="", help="vo_eval executable (default: from the build)")
    parser.add_argument("--no-images", action="store_true",
                        help="do not subscribe to vo/tracking_image (an rviz without the image display)")
    args = parser.parse_args()

    dataset = os.path.abspath(args.dataset)
    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    build = os.environ.get("PLANETARY_VO_BUILD", os.path.join(root, "build"))
    vo_eval = args.vo_eval or os.path.join(build, "devel", "lib", "planetary_vo", "vo_eval")
    if not os.path.isfile(vo_eval):
        sys.exit("soak: no vo_eval at %s (build first)" % vo_eval)
    gt_positions = read_ground_truth_positions(dataset)
    first_position = gt_positions[0]

    os.environ["ROS_MASTER_URI"] = "http://localhost:%d" % args.port
    launch_cmd = ["roslaunch", "-p", str(args.port), "planetary_vo", "soak.launch", "dataset:=" + dataset,
                  "rate:=%g" % args.rate, "queue_size:=%d" % args.queue_size]
    if args.config:
        launch_cmd.append("config:=" + os.path.abspath(args.config))
    launch_log = open(os.path.join(out_dir, "roslaunch.log"), "w")
    launch = subprocess.Popen(launch_cmd, stdout=launch_log, stderr=subprocess.STDOUT, start_new_session=True)

    import rospy  # after ROS_MASTER_URI is set
    from geometry_msgs.msg import PoseStamped
    from planetary_vo.msg import VoStatus

    lock = threading.Lock()
    loops = []  # each: {"gt": {stamp_ns: PoseStamped}, "start_ns": ...}
    statuses = {}  # stamp_ns -> state
    received = {}  # stamp_ns -> the VO's count of images received so far (VoStatus.num_images)
    published_wall = {}  # stamp_ns -> when this process got the image's ground_truth/pose (the player sends it
    status_wall = {}  # with the image) and (when its vo/status came, the pipeline's ms): the VO's lag behind
    notes = {}  # stamp_ns -> state, scale source and message of each recovery and scale-source change
    last_scale_source = [None]
    poses = {}  # stamp_ns -> PoseStamped
    raw_counts = {}
    times_ms = []  # (pipeline, ROS layer) per processed frame

    def on_gt(m):
        p = m.pose.position
        with lock:
            if not loops or (abs(p.x - first_position[0]) < 1e-6 and abs(p.y - first_position[1]) < 1e-6 and
                             abs(p.z - first_position[2]) < 1e-6 and len(loops[-1]["gt"]) > 1):
                loops.append({"gt": {}})
            loops[-1]["gt"][m.header.stamp.to_nsec()] = compact(m)
            published_wall[m.header.stamp.to_nsec()] = time.monotonic()

    def on_status(m):
        if m.header.stamp.is_zero():
            return  # the watchdog's "no input" status
        with lock:
            statuses[m.header.stamp.to_nsec()] = m.state
            received[m.header.stamp.to_nsec()] = m.num_images
            status_wall[m.header.stamp.to_nsec()] = (time.monotonic(), m.total_ms if m.processed else None)
            if m.state == VoStatus.STATE_RECOVERED or m.scale_source != last_scale_source[0]:
                notes[m.header.stamp.to_nsec()] = "%s [%s] %s" % (m.state_name, m.scale_source, m.message)
                last_scale_source[0] = m.scale_source
            if m.processed:
                times_ms.append((m.total_ms, m.ros_overhead_ms))

    def on_pose(m):
        with lock:
            poses[m.header.stamp.to_nsec()] = compact(m)

    def counter(topic):
        def cb(_):
            with lock:
                raw_counts[topic] = raw_counts.get(topic, 0) + 1
        return cb

    # Wait for the master of the launch.
    deadline = time.monotonic() + 60.0
    while True:
        try:
            rospy.get_master().getPid()
            break
        except Exception:
            if time.monotonic() > deadline or launch.poll() is not None:
                sys.exit("soak: roslaunch did not start a master (see %s/roslaunch.log)" % out_dir)
            time.sleep(0.5)
    rospy.init_node("soak_benchmark", disable_signals=True)
    subs = [rospy.Subscriber("ground_truth/pose", PoseStamped, on_gt, queue_size=100000),
            rospy.Subscriber("vo/status", VoStatus, on_status, queue_size=100000),
            rospy.Subscriber("vo/pose", PoseStamped, on_pose, queue_size=100000)]
    raw_topics = ["vo/odometry", "vo/path", "vo/map_points", "vo/map_events", "nav/odometry", "/tf"]
    if not args.no_images:
        raw_topics.append("vo/tracking_image")
    for topic in raw_topics:
        subs.append(rospy.Subscriber(topic, rospy.AnyMsg, counter(topic), queue_size=10))

    pid = find_manager_pid("vo_manager")
    if pid is None:
        launch.send_signal(signal.SIGINT)
        sys.exit("soak: no vo_manager process")
    print("soak: %s at %gx for %g min, vo_manager pid %d" % (dataset, args.rate, args.minutes, pid), flush=True)
    memory = []  # (seconds since the first image, loops started, VmRSS kB, machine busy and steal fractions)
    last_cpu = cpu_times()
    start = None
    end_time = None
    interrupted = False
    try:
        while launch.poll() is None:
            time.sleep(args.sample_s)
            with lock:
                n_loops = len(loops)
            if n_loops == 0:
                continue
            if start is None:
                start = time.monotonic()
                end_time = start + 60.0 * args.minutes
            kb = rss_kb(pid)
            cpu = cpu_times()
            busy, steal = ((cpu[0] - last_cpu[0]) / max(1, cpu[2] - last_cpu[2]),
                           (cpu[1] - last_cpu[1]) / max(1, cpu[2] - last_cpu[2]))
            last_cpu = cpu
            memory.append((time.monotonic() - start, n_loops, kb, round(busy, 4), round(steal, 4)))
            if len(memory) % max(1, int(300 / args.sample_s)) == 0:
                print("soak: %.1f min, loop %d, VmRSS %.1f MB" % (memory[-1][0] / 60, n_loops, (kb or 0) / 1024.0),
                      flush=True)
            if time.monotonic() >= end_time:
                break
    except KeyboardInterrupt:  # Ctrl-C: stop the graph and score the loops completed so far
        interrupted = True
        print("soak: interrupted; stopping the graph and scoring the complete loops", flush=True)
    alive = launch.poll() is None
    launch.send_signal(signal.SIGINT)
    try:
        launch.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(launch.pid, signal.SIGKILL)
    for s in subs:
        s.unregister()
    if not alive:
        print("soak: the launch ended early (see %s/roslaunch.log)" % out_dir)

    # Score every complete loop (the last one was cut by the end of the soak).
    with lock:
        complete = loops[:-1]
    results = []
    tmp = tempfile.mkdtemp(prefix="soak_", dir=out_dir)
    received_before = 0  # images the VO had received by the end of the previous loop
    for k, loop in enumerate(complete):
        stamps = sorted(loop["gt"])
        t0 = stamps[0]
        reported = [s for s in stamps if s in statuses]
        estimated = [s for s in stamps if statuses.get(s) in (VoStatus.STATE_TRACKING, VoStatus.STATE_RECOVERED)
                     and s in poses]
        # Two ways an image ends without a status here: the VO never got it (its input queue overflowed: the
        # VO fell behind; its own count num_images shows it), or it was processed but the status was lost on
        # its way to this subscriber (the publisher's queue overflowed while this Python process lagged).
        received_end = max([received[s] for s in reported] + [received_before])
        not_received = max(0, len(stamps) - (received_end - received_before))
        received_before = received_end
        row = {"loop": k, "images": len(stamps), "dropped": len(stamps) - len(reported),
               "not_received_by_vo": not_received, "status_lost": max(0, len(stamps) - len(reported) - not_received),
               "estimated": len(estimated), "ate_percent": None, "sim3_scale": None,
               # the VO's lag: its status' arrival here minus the image's ground_truth/pose arrival
               "lag_ms": median_and_max([1e3 * (status_wall[s][0] - published_wall[s]) for s in stamps
                                         if s in status_wall and s in published_wall]),
               "pipeline_ms": median_and_max([status_wall[s][1] for s in stamps
                                              if s in status_wall and status_wall[s][1] is not None]),
               "recoveries": ["%.1f s: %s" % ((s - t0) * 1e-9, notes[s]) for s in stamps if s in notes]}
        if len(estimated) >= 10:
            gt_file, est_file, js = (os.path.join(tmp, n) for n in ("gt.tum", "est.tum", "eval.json"))
            with open(gt_file, "w") as f:
                for s in stamps:
                    f.write(tum_line((s - t0) * 1e-9, loop["gt"][s]))
            with open(est_file, "w") as f:
                for s in estimated:
                    f.write(tum_line((s - t0) * 1e-9, poses[s]))
            r = subprocess.run([vo_eval, "--gt", gt_file, "--est", est_file, "--json", js], capture_output=True,
                               text=True)
            if r.returncode == 0:
                with open(js) as f:
                    report = json.load(f)
                row["ate_percent"] = report.get("ate_rmse_percent_of_path")
                # metres per VO unit in this loop: constant when the scale does not drift across the losses
                row["sim3_scale"] = report.get("alignment", {}).get("scale")
        results.append(row)

    images = sum(r["images"] for r in results)
    dropped = sum(r["dropped"] for r in results)
    ates = [r["ate_percent"] for r in results if r["ate_percent"] is not None]
    summary = {"dataset": dataset, "rate": args.rate, "minutes": args.minutes, "queue_size": args.queue_size,
               "config": args.config or "config/default.yaml", "loops": results, "memory": memory,
               "raw_messages": raw_counts, "tracking_image_subscribed": not args.no_images,
               "interrupted": interrupted}
    with open(os.path.join(out_dir, "soak.json"), "w") as f:
        json.dump(summary, f, indent=1)
    print("soak: %d complete loops of %s at %gx, %.1f min" % (len(results), os.path.basename(dataset), args.rate,
                                                              memory[-1][0] / 60 if memory else 0))
    after_first = [m for m in memory if m[1] >= 2 and m[2]]
    if after_first:
        kb0, kb1 = after_first[0][2], after_first[-1][2]
        peak = max(m[2] for m in after_first)
        # Least-squares trend of VmRSS over time after the first loop.
        ts = [m[0] for m in after_first]
        ks = [m[2] for m in after_first]
        tm, km = statistics.fmean(ts), statistics.fmean(ks)
        den = sum((t - tm) ** 2 for t in ts)
        slope = sum((t - tm) * (v - km) for t, v in zip(ts, ks)) / den if den > 0 else 0.0
        print("memory (VmRSS of vo_manager): %.1f MB after the first loop, %.1f MB at the end (%+.2f MB), peak "
              "%.1f MB, trend %+.2f MB/h" % (kb0 / 1024, kb1 / 1024, (kb1 - kb0) / 1024, peak / 1024,
                                            slope * 3600 / 1024))
    not_received = sum(r["not_received_by_vo"] for r in results)
    if memory:
        busy = [m[3] for m in memory]
        steal = [m[4] for m in memory]
        print("machine (all %d cores, every %gs sample): busy median %.0f %%, max %.0f %%; steal (other guests of "
              "the VM host) median %.1f %%, max %.1f %%" % (os.cpu_count(), args.sample_s, 100 * statistics.median(busy),
                                                          100 * max(busy), 100 * statistics.median(steal),
                                                          100 * max(steal)))
    print("frames: %d published, %d without a status here (%.3f %%): %d never reached the VO (dropped by its "
          "input queue), %d processed but their status lost on the way to this subscriber" %
          (images, dropped, 100.0 * dropped / images if images else 0.0, not_received, dropped - not_received))
    if ates:
        first = ates[0]
        within = sum(1 for a in ates if a <= 2.0 * first)
        print("ATE per loop (Sim(3), %% of path): first %.3f, median %.3f, worst %.3f; %d of %d loops within 2x of "
              "the first" % (first, statistics.median(ates), max(ates), within, len(ates)))
    scales = [r["sim3_scale"] for r in results if r["sim3_scale"]]
    if len(scales) >= 2:
        ratios = [b / a for a, b in zip(scales, scales[1:])]
        print("scale across the losses (Sim(3) metres per VO unit, loop by loop): first %.4g, last %.4g; "
              "loop-to-loop ratio median %.3f, range %.3f-%.3f" %
              (scales[0], scales[-1], statistics.median(ratios), min(ratios), max(ratios)))
    if times_ms:
        def pct(v, q):
            v = sorted(v)
            return v[min(len(v) - 1, int(q * len(v)))]
        pipe = [a for a, _ in times_ms]
        ros = [b for _, b in times_ms]
        print("per processed frame: pipeline median %.2f ms, p99 %.2f ms; ROS layer median %.2f ms, p99 %.2f ms "
              "(%d frames)" % (pct(pipe, 0.5), pct(pipe, 0.99), pct(ros, 0.5), pct(ros, 0.99), len(times_ms)))
    print("raw messages received: " + ", ".join("%s %d" % kv for kv in sorted(raw_counts.items())))
    print("written: %s" % os.path.join(out_dir, "soak.json"))


if __name__ == "__main__":
    main()
