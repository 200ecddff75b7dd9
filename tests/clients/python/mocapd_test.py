#!/usr/bin/python3
"""The mocapd Python package against a real daemon: the build's mocapd (environment MOCAPD) on
loopback with no configuration, so the fake hand scene, read through `from mocapd import Client`,
the `python3 -m mocapd` command line, the mocap_client.py script and the CSV example."""

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np

from mocapd import Client, Pose

SOURCE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")
PYTHON_CLIENT_DIR = os.path.join(SOURCE_DIR, "clients", "python")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class MocapdPackageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.address = "127.0.0.1:%d" % free_port()
        cls.daemon = subprocess.Popen([os.environ["MOCAPD"], "--listen", cls.address,
                                       "--log-level", "warning"])
        cls.client = Client(cls.address)
        # A generous limit for a loaded machine, not a timing assertion.
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if cls.client.status().poses_published > 0:
                    break
            except cls.client.RpcError:
                pass
            if cls.daemon.poll() is not None:
                raise RuntimeError("mocapd exited with %d" % cls.daemon.returncode)
            time.sleep(0.2)
        else:
            cls.tearDownClass()
            raise RuntimeError("mocapd published no pose in 60 s")
        cls.skeleton = cls.client.skeleton()

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.daemon.send_signal(signal.SIGTERM)
        cls.daemon.wait(timeout=30)

    def take(self, count, joints=None):
        poses = []
        for pose in self.client.poses(joints):
            poses.append(pose)
            if len(poses) == count:
                break
        return poses

    def test_poses_are_numpy_arrays_of_the_skeletons_joints_and_they_move(self):
        names = [p.name for p in self.skeleton.points]
        poses = self.take(25)
        self.assertEqual(len(poses), 25)
        for pose in poses:
            self.assertIsInstance(pose, Pose)
            self.assertEqual(pose.joint_names, names)
            self.assertEqual(pose.positions.shape, (len(names), 3))
            self.assertEqual(pose.positions.dtype, np.float64)
            self.assertEqual(list(pose.joints), names)
            for name in names:
                self.assertEqual(pose.joints[name].shape, (3,))
            self.assertEqual(pose.dofs.shape, (len(self.skeleton.dofs),))
            self.assertEqual(pose.orientations.shape, (len(self.skeleton.segments), 4))
            np.testing.assert_allclose(np.linalg.norm(pose.orientations, axis=1), 1, atol=1e-9)
            self.assertIsNotNone(pose.reference_error_mm)  # the fake scene knows the truth
        frames = [pose.frame for pose in poses]
        self.assertEqual(frames, sorted(frames))
        self.assertGreater(frames[-1], frames[0])
        # The hand's fingers flex over a second of its motion: some joint moves by millimetres.
        moved = np.linalg.norm(poses[-1].positions - poses[0].positions, axis=1)
        self.assertGreater(moved.max(), 0.002, moved)
        self.assertGreater(np.abs(poses[-1].dofs - poses[0].dofs).max(), 0.01)

    def test_a_subset_of_joints_comes_in_the_order_asked(self):
        names = [p.name for p in self.skeleton.points][-2:][::-1]
        pose = self.take(1, joints=names)[0]
        self.assertEqual(pose.joint_names, names)
        self.assertEqual(pose.positions.shape, (2, 3))
        np.testing.assert_array_equal(pose.joints[names[1]], pose.positions[1])

    def test_poses_for_some_seconds_ends_the_stream(self):
        start = time.monotonic()
        count = sum(1 for _ in self.client.poses(seconds=1.5))
        self.assertGreater(count, 0)
        self.assertLess(time.monotonic() - start, 15)

    def test_the_command_line_is_the_modules_main(self):
        def run(*args):
            return subprocess.run([sys.executable, "-m", "mocapd", *args, "--server", self.address],
                                  capture_output=True, text=True, timeout=60)
        self.assertEqual(run("health").stdout, "SERVING\n")
        streamed = run("stream", "--count", "3")
        self.assertEqual(streamed.returncode, 0, streamed.stderr)
        lines = [json.loads(line) for line in streamed.stdout.splitlines()]
        self.assertEqual(len(lines), 3)
        self.assertEqual(set(lines[0]["joints"]), {p.name for p in self.skeleton.points})
        # The script of older instructions says the same.
        script = subprocess.run([sys.executable, os.path.join(PYTHON_CLIENT_DIR, "mocap_client.py"),
                                 "health", "--server", self.address],
                                capture_output=True, text=True, timeout=60)
        self.assertEqual(script.stdout, "SERVING\n", script.stderr)

    def test_the_csv_example_records_a_row_a_pose(self):
        with tempfile.TemporaryDirectory() as folder:
            out = os.path.join(folder, "poses.csv")
            example = os.path.join(PYTHON_CLIENT_DIR, "examples", "record_csv.py")
            done = subprocess.run([sys.executable, example, out, "--seconds", "1.5",
                                   "--server", self.address],
                                  capture_output=True, text=True, timeout=60)
            self.assertEqual(done.returncode, 0, done.stderr)
            with open(out, newline="") as f:
                rows = list(csv.reader(f))
        joints = len(self.skeleton.points)
        self.assertEqual(rows[0][:2], ["time_s", "frame"])
        self.assertEqual(len(rows[0]), 2 + 3 * joints)
        self.assertGreater(len(rows), 2)
        self.assertEqual(float(rows[1][0]), 0.0)
        self.assertTrue(all(len(row) == 2 + 3 * joints for row in rows[1:]))
        self.assertGreater(float(rows[-1][0]), 0.0)


if __name__ == "__main__":
    unittest.main(verbosity=2)
