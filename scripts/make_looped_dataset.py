#!/usr/bin/python3
"""Writes a planetary_vo dataset that plays another one N times in a row, as the player's ~loop does (each loop
shifted by the span of the images plus one mean image interval), so that vo_run reproduces offline what the
soak benchmark (scripts/soak_benchmark.py) sees through the nodelet: at every loop the camera jumps back to the
start of the descent. Images are symbolic links; times.txt and groundtruth.txt are rewritten; camera.yaml,
sensors.yaml and sequence.yaml are copied. IMU and altimeter streams are not looped (vision only).

Usage:
  /usr/bin/python3 scripts/make_looped_dataset.py SRC DST --loops 12
  build/devel/lib/planetary_vo/vo_run --dataset DST --output DST.tum --frame-log DST.frames
"""
import argparse
import os
import shutil


def data_lines(path):
    with open(path) as f:
        return [line.split() for line in f if line.strip() and not line.startswith("#")]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("src", help="planetary_vo dataset folder")
    parser.add_argument("dst", help="new folder (replaced if it exists)")
    parser.add_argument("--loops", type=int, default=12)
    args = parser.parse_args()
    src, dst = os.path.abspath(args.src), os.path.abspath(args.dst)
    if os.path.exists(dst):
        shutil.rmtree(dst)
    os.makedirs(os.path.join(dst, "images"))
    for name in ("camera.yaml", "sensors.yaml", "sequence.yaml"):
        if os.path.exists(os.path.join(src, name)):
            shutil.copy(os.path.join(src, name), dst)
    times = [float(v[0]) for v in data_lines(os.path.join(src, "times.txt"))]
    ground_truth = data_lines(os.path.join(src, "groundtruth.txt"))
    images = sorted(os.listdir(os.path.join(src, "images")))
    n = len(times)
    if len(images) != n or len(ground_truth) != n:
        raise SystemExit("make_looped_dataset: %d times, %d images, %d ground-truth poses" %
                         (n, len(images), len(ground_truth)))
    span = times[-1] - times[0]
    period = span + (span / (n - 1) if n > 1 else 0.1)
    with open(os.path.join(dst, "times.txt"), "w") as t_out, \
            open(os.path.join(dst, "groundtruth.txt"), "w") as g_out:
        t_out.write("# timestamp[s] of images/NNNNNN.png, one line per image (%d loops of %s)\n" % (args.loops, src))
        g_out.write("# t tx ty tz qx qy qz qw (T_world_cam), %d loops\n" % args.loops)
        k = 0
        for loop in range(args.loops):
            for i in range(n):
                shift = loop * period
                t_out.write("%.9f\n" % (times[i] + shift))
                g_out.write(" ".join(["%.9f" % (float(ground_truth[i][0]) + shift)] + ground_truth[i][1:]) + "\n")
                os.symlink(os.path.join(src, "images", images[i]), os.path.join(dst, "images", "%06d.png" % k))
                k += 1
    print("make_looped_dataset: %d images (%d loops of %d, period %.3f s) in %s" % (k, args.loops, n, period, dst))


if __name__ == "__main__":
    main()
