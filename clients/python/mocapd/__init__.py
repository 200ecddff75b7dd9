"""mocapd's Python client: live poses from the motion-capture daemon as numpy arrays.

    from mocapd import Client

    for pose in Client("127.0.0.1:50051").poses():
        wrist = pose.joints["l_wrist"]    # numpy array (x, y, z), metres, world frame Z up
        print(pose.frame, wrist)

Client also reads the status and the skeleton, checks health, and drives the daemon (reacquire,
background capture, body fit); `python3 -m mocapd --help` is the same as a command.
Needs Debian's python3-grpcio, python3-protobuf and python3-numpy, and the generated gRPC stubs
(package mocap.v1), installed beside this package by `cmake --install` or found in a build tree.
"""

from mocapd.client import NEAR_LIVE_CHANNEL_OPTIONS, Client
from mocapd.pose import Pose, pose_to_dict

__all__ = ["Client", "Pose", "pose_to_dict", "NEAR_LIVE_CHANNEL_OPTIONS"]
