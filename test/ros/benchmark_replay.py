#!/usr/bin/python3
"""Benchmark (not a test) of the VO nodelet while a replay runs: listens to vo/status and vo/pose and prints
the mean pipeline time per frame (VoStatus.total_ms), the mean time the ROS layer adds per frame
(VoStatus.ros_overhead_ms: conversion, checks, publishing), and the end-to-end rate of vo/pose in poses per
wall-clock second between the first and the last pose. Stops after `--frames` poses or `--idle` seconds
without a pose (a minute before the first). Usage (with a replay running, e.g. replay.launch bag:=... rate:=50 queue_size:=1000):
  /usr/bin/python3 test/ros/benchmark_replay.py --frames 40
"""
import argparse
import time

import rospy
from geometry_msgs.msg import PoseStamped
from planetary_vo.msg import VoStatus


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=0, help="stop after this many poses (0: on idle only)")
    parser.add_argument("--idle", type=float, default=10.0, help="stop after this long without a pose [s]")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("benchmark_replay", anonymous=True)
    pose_times, statuses = [], []
    rospy.Subscriber("vo/pose", PoseStamped, lambda m: pose_times.append(time.monotonic()), queue_size=10000)
    rospy.Subscriber("vo/status", VoStatus, lambda m: statuses.append(m) if m.processed else None,
                     queue_size=10000)
    start = time.monotonic()
    while not rospy.is_shutdown():
        time.sleep(0.1)
        # Before the first pose, wait up to a minute for the replay to start.
        last, idle = (pose_times[-1], args.idle) if pose_times else (start, 60.0)
        if (args.frames and len(pose_times) >= args.frames) or time.monotonic() - last > idle:
            break
    n = len(statuses)
    if n == 0 or len(pose_times) < 2:
        print("no frames processed")
        return
    total = sum(s.total_ms for s in statuses) / n
    ros = sum(s.ros_overhead_ms for s in statuses) / n
    rate = (len(pose_times) - 1) / (pose_times[-1] - pose_times[0])
    print("frames %d  pipeline %.2f ms/frame  ROS layer %.2f ms/frame (%.1f %% of the pipeline)  "
          "end-to-end %.2f poses/s" % (n, total, ros, 100.0 * ros / total, rate))


if __name__ == "__main__":
    main()
