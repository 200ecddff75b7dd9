"""Finds the gRPC stubs the build generates from proto/mocap/v1/mocap.proto (package mocap.v1:
mocap_pb2, mocap_pb2_grpc): installed on Python's path beside this package, or in a build tree."""

import importlib
import os
import sys

_SOURCE_TREE_BUILD = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                  "..", "..", "..", "build", "python")


def _has_stubs(directory):
    return bool(directory) and os.path.isfile(os.path.join(directory, "mocap", "v1", "mocap_pb2.py"))


def load(stubs_dir=None):
    """Returns the modules (mocap_pb2, mocap_pb2_grpc). Looks in stubs_dir, then $MOCAP_PY_STUBS,
    then Python's path (an installed mocapd), then build/python of the source tree this package
    is in. Raises ImportError saying where it looked."""
    for directory in (stubs_dir, os.environ.get("MOCAP_PY_STUBS")):
        if _has_stubs(directory):
            path = os.path.abspath(directory)
            if path not in sys.path:
                sys.path.insert(0, path)
            break
    try:
        return (importlib.import_module("mocap.v1.mocap_pb2"),
                importlib.import_module("mocap.v1.mocap_pb2_grpc"))
    except ImportError:
        if not _has_stubs(_SOURCE_TREE_BUILD):
            raise ImportError(
                "mocapd: no generated stubs (mocap.v1): install mocapd (cmake --install), or build "
                "the mocap_proto_python target and pass stubs_dir=<build>/python (--stubs) or set "
                "MOCAP_PY_STUBS; looked in %s"
                % ", ".join(d for d in (stubs_dir, os.environ.get("MOCAP_PY_STUBS"),
                                        "Python's path", _SOURCE_TREE_BUILD) if d)) from None
        sys.path.insert(0, os.path.abspath(_SOURCE_TREE_BUILD))
        return (importlib.import_module("mocap.v1.mocap_pb2"),
                importlib.import_module("mocap.v1.mocap_pb2_grpc"))
