#!/usr/bin/python3
"""mocapd's Python client as a script: the same command line as `python3 -m mocapd` (see
mocapd/__main__.py), for a source checkout where the mocapd package is beside this file.

    mocap_client.py stream [--count N] [--joints a,b]   JSON lines, one pose a line
    mocap_client.py status | skeleton | health | reacquire | background [--frames N]
    mocap_client.py fit-body [--frames N] [--apply]

As a library, import the package instead: `from mocapd import Client` (MocapClient here is the same
class, kept for older scripts).
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from mocapd.__main__ import main  # noqa: E402 (after the path is set)
from mocapd.client import Client as MocapClient  # noqa: E402,F401
from mocapd.pose import pose_to_dict  # noqa: E402,F401

if __name__ == "__main__":
    sys.exit(main(prog="mocap_client.py"))
