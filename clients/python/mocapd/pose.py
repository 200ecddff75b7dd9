"""A tracked pose as numpy arrays, and as the JSON-ready dict the command line prints."""

import numpy as np


class Pose:
    """One pose from mocapd's stream. Positions are metres in the daemon's world frame
    (right-handed, Z up); angles radians.

    frame                 the frame set's sequence number
    capture_monotonic_ns  when its frames were exposed (CLOCK_MONOTONIC of the daemon's host)
    capture_wall_ns, publish_monotonic_ns
    joint_names           the joints sent, in order (all of the skeleton's unless asked for fewer)
    positions             numpy array (joints, 3)
    joints                dict name -> numpy array (3,), rows of `positions`
    dofs                  numpy array (DOFs,), in the order of the skeleton's dofs
    orientations          numpy array (segments, 4): each segment's world rotation (w, x, y, z)
    score, spread, missed_before, body_version
    silhouette_fit        None when the daemon does not compute it (the hand)
    reference_error_mm    None unless the source knows the truth (the fake scene)
    message               the mocap.v1.Pose it came from
    """

    __slots__ = ("frame", "capture_monotonic_ns", "capture_wall_ns", "publish_monotonic_ns",
                 "joint_names", "positions", "joints", "dofs", "orientations", "score", "spread",
                 "missed_before", "body_version", "silhouette_fit", "reference_error_mm",
                 "message")

    def __init__(self, message):
        self.message = message
        self.frame = message.frame_sequence
        self.capture_monotonic_ns = message.capture_monotonic_ns
        self.capture_wall_ns = message.capture_wall_ns
        self.publish_monotonic_ns = message.publish_monotonic_ns
        self.joint_names = [j.name for j in message.joints]
        self.positions = np.array([(j.position.x, j.position.y, j.position.z)
                                   for j in message.joints], dtype=np.float64).reshape(-1, 3)
        self.joints = dict(zip(self.joint_names, self.positions))
        self.dofs = np.array(message.dofs, dtype=np.float64)
        self.orientations = np.array([(q.w, q.x, q.y, q.z) for q in message.segment_orientations],
                                     dtype=np.float64).reshape(-1, 4)
        self.score = message.score
        self.spread = message.spread
        self.missed_before = message.missed_before
        self.body_version = message.body_version
        self.silhouette_fit = message.silhouette_fit if message.HasField("silhouette_fit") else None
        self.reference_error_mm = (message.reference_error_mm
                                   if message.HasField("reference_error_mm") else None)

    def to_dict(self):
        """The pose as `python3 -m mocapd stream` prints it (plain lists, JSON-ready)."""
        return pose_to_dict(self.message)

    def __repr__(self):
        return "Pose(frame=%d, %d joints, %d dofs)" % (self.frame, len(self.joint_names),
                                                       self.dofs.size)


def pose_to_dict(pose):
    """A mocap.v1.Pose as a JSON-ready dict: one line of `stream`'s output."""
    out = {
        "frame": pose.frame_sequence,
        "capture_monotonic_ns": pose.capture_monotonic_ns,
        "capture_wall_ns": pose.capture_wall_ns,
        "publish_monotonic_ns": pose.publish_monotonic_ns,
        "joints": {j.name: [j.position.x, j.position.y, j.position.z] for j in pose.joints},
        "dofs": list(pose.dofs),
        "score": pose.score,
        "spread": pose.spread,
        "missed_before": pose.missed_before,
        "body_version": pose.body_version,
    }
    for optional in ("silhouette_fit", "reference_error_mm"):
        if pose.HasField(optional):
            out[optional] = getattr(pose, optional)
    return out
