#!/usr/bin/python3
"""Records mocapd's poses to a CSV file: one row a pose, the capture time in seconds from the first
pose, the frame number, then x, y, z (metres, world frame Z up) of every joint.

    python3 record_csv.py poses.csv [--seconds 10] [--server 127.0.0.1:50051] [--joints a,b]

Uses the mocapd package (installed, or clients/python of a checkout, found from here).
"""

import argparse
import csv
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mocapd import Client  # noqa: E402 (after the path is set)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="the CSV file to write")
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--server", default="127.0.0.1:50051")
    parser.add_argument("--joints", default="", help="comma-separated joint names (default all)")
    parser.add_argument("--stubs", help="the generated stubs' folder when not installed")
    args = parser.parse_args()

    joints = [j for j in args.joints.split(",") if j] or None
    rows = 0
    with Client(args.server, stubs_dir=args.stubs) as client, open(args.out, "w", newline="") as f:
        writer = csv.writer(f)
        first_ns = None
        for pose in client.poses(joints, seconds=args.seconds):
            if first_ns is None:
                first_ns = pose.capture_monotonic_ns
                writer.writerow(["time_s", "frame"] + ["%s_%s" % (name, axis)
                                                       for name in pose.joint_names
                                                       for axis in "xyz"])
            time_s = (pose.capture_monotonic_ns - first_ns) / 1e9
            writer.writerow(["%.3f" % time_s, pose.frame] +
                            ["%.4f" % v for v in pose.positions.ravel()])
            rows += 1
    print("record_csv: %d poses in %.0f s to %s" % (rows, args.seconds, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
