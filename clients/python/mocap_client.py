#!/usr/bin/python3
"""Python client of mocapd: stream poses, read the status and the skeleton, check health.

Uses Debian's python3-grpcio (run it with /usr/bin/python3) and the stubs the build generates
into <build>/python (mocap/v1/mocap_pb2.py, mocap_pb2_grpc.py). Point --stubs (or $MOCAP_PY_STUBS)
at that folder; by default it looks in ../../build/python beside this file.

As a library:
    client = MocapClient("127.0.0.1:50051", token=None)
    for pose in client.stream_poses(joints=["wrist"]):
        ...

As a command:
    mocap_client.py stream [--count N] [--joints a,b]   JSON lines, one pose a line
    mocap_client.py status | skeleton | health | reacquire | background [--frames N]
    mocap_client.py fit-body [--frames N] [--apply]   the fitted body model (YAML) on stdout,
                                            the figures as comments at its top
"""

import argparse
import json
import os
import sys


def _import_stubs(stubs_dir):
    """Imports the generated modules from stubs_dir (or the default build tree)."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = [stubs_dir, os.environ.get("MOCAP_PY_STUBS"),
                  os.path.join(here, "..", "..", "build", "python")]
    for directory in candidates:
        if directory and os.path.isfile(os.path.join(directory, "mocap", "v1", "mocap_pb2.py")):
            sys.path.insert(0, os.path.abspath(directory))
            break
    else:
        raise SystemExit("mocap_client: no generated stubs in %s: build the mocap_proto_python "
                         "target, then pass --stubs <build>/python or set MOCAP_PY_STUBS"
                         % ", ".join(d for d in candidates if d))
    from mocap.v1 import mocap_pb2, mocap_pb2_grpc  # noqa: E402 (found at run time)
    return mocap_pb2, mocap_pb2_grpc


# Keeps a slow reader near live: without BDP probing and with a small per-stream window, only a
# few poses wait in this client's buffers; the daemon drops the older ones and says how many in
# Pose.missed_before (see clients/mocapctl/daemon_client.h).
NEAR_LIVE_CHANNEL_OPTIONS = [
    ("grpc.http2.bdp_probe", 0),
    ("grpc.http2.lookahead_bytes", 16 * 1024),
]


class MocapClient:
    def __init__(self, server="127.0.0.1:50051", token=None, tls_ca=None, stubs_dir=None,
                 tls_cert=None, tls_key=None):
        """tls_ca: the daemon's certificate (PEM) to trust, for TLS; tls_cert and tls_key: this
        client's certificate and key (PEM), for a daemon that asks for one (tls.client_ca)."""
        import grpc
        self._grpc = grpc
        self.pb, pb_grpc = _import_stubs(stubs_dir)
        if bool(tls_cert) != bool(tls_key):
            raise ValueError("tls_cert and tls_key go together")
        if tls_cert and not tls_ca:
            raise ValueError("tls_cert needs tls_ca (the daemon's certificate to trust)")
        if tls_ca:
            def read(path):
                with open(path, "rb") as f:
                    return f.read()
            credentials = grpc.ssl_channel_credentials(
                root_certificates=read(tls_ca),
                private_key=read(tls_key) if tls_key else None,
                certificate_chain=read(tls_cert) if tls_cert else None)
            self._channel = grpc.secure_channel(server, credentials, NEAR_LIVE_CHANNEL_OPTIONS)
        else:
            self._channel = grpc.insecure_channel(server, NEAR_LIVE_CHANNEL_OPTIONS)
        self._stub = pb_grpc.MocapServiceStub(self._channel)
        self._metadata = [("authorization", "Bearer " + token)] if token else []

    def close(self):
        self._channel.close()

    def stream_poses(self, joints=None):
        """Yields mocap.v1.Pose messages until the daemon ends the stream; cancel by closing."""
        request = self.pb.StreamPosesRequest(joints=joints or [])
        return self._stub.StreamPoses(request, metadata=self._metadata)

    def status(self):
        return self._stub.GetStatus(self.pb.GetStatusRequest(), metadata=self._metadata)

    def skeleton(self):
        return self._stub.GetSkeleton(self.pb.GetSkeletonRequest(), metadata=self._metadata)

    def reacquire(self):
        """Has the tracker find the subject again from the next frame set."""
        return self._stub.Reacquire(self.pb.ReacquireRequest(), metadata=self._metadata)

    def capture_background(self, frames=0):
        """Has the daemon learn the empty scene as every camera's background from its next
        `frames` frames (0: the daemon's default); returns the CaptureBackgroundResponse (frames
        used per camera, warnings about cameras whose image changed during the capture or differs
        from the background it replaced)."""
        request = self.pb.CaptureBackgroundRequest(frames=frames)
        return self._stub.CaptureBackground(request, metadata=self._metadata,
                                            timeout=60 + max(frames, 25))

    def fit_body(self, frame_sets=0, apply=False):
        """Fits the body model to the subject, who stands in its fit pose turning slowly in place,
        from `frame_sets` frame sets half a second apart (0: the daemon's default, 5); with
        `apply` the daemon tracks with the fitted body from then on. Returns the FitBodyResponse
        (the fitted body model as YAML in body_model_yaml, the proportions, the scale, the sets
        used, the body_version it is tracked as when applied)."""
        request = self.pb.FitBodyRequest(frame_sets=frame_sets, apply=apply)
        return self._stub.FitBody(request, metadata=self._metadata,
                                  timeout=60 + 3 * max(frame_sets, 5))

    def health(self, service=""):
        """grpc.health.v1.Health/Check without its stubs (Debian ships none): the request is
        HealthCheckRequest{service}, the reply HealthCheckResponse{status}, both tiny enough to
        encode by hand. Returns "SERVING", "NOT_SERVING", "UNKNOWN" or "SERVICE_UNKNOWN"."""
        name = service.encode()
        request = (b"\x0a" + bytes([len(name)]) + name) if name else b""
        check = self._channel.unary_unary("/grpc.health.v1.Health/Check",
                                          request_serializer=lambda raw: raw,
                                          response_deserializer=lambda raw: raw)
        reply = check(request, timeout=5)
        value = reply[1] if len(reply) >= 2 and reply[0] == 0x08 else 0
        return {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}.get(value, "UNKNOWN")


def pose_to_dict(pose):
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


def main():
    parser = argparse.ArgumentParser(description="Python client of mocapd")
    parser.add_argument("command", choices=["stream", "status", "skeleton", "health", "reacquire",
                                            "background", "fit-body"])
    parser.add_argument("--server", default="127.0.0.1:50051")
    parser.add_argument("--token", default=os.environ.get("MOCAP_TOKEN"))
    parser.add_argument("--tls-ca", help="the daemon's certificate (PEM): connect with TLS")
    parser.add_argument("--tls-cert", help="this client's certificate (PEM), with --tls-key")
    parser.add_argument("--tls-key", help="this client's private key (PEM)")
    parser.add_argument("--stubs", help="folder of the generated stubs (<build>/python)")
    parser.add_argument("--count", type=int, default=0, help="stream: stop after N poses")
    parser.add_argument("--joints", default="", help="stream: comma-separated joint names")
    parser.add_argument("--frames", type=int, default=0,
                        help="background: frames per camera to learn from (0: the daemon's 25); "
                        "fit-body: frame sets to fit from (0: the daemon's 5)")
    parser.add_argument("--apply", action="store_true",
                        help="fit-body: the daemon also tracks with the fitted body from then on")
    args = parser.parse_args()

    client = MocapClient(args.server, args.token, args.tls_ca, args.stubs, args.tls_cert,
                         args.tls_key)
    from google.protobuf import json_format
    try:
        if args.command == "stream":
            joints = [j for j in args.joints.split(",") if j]
            stream = client.stream_poses(joints)
            received = 0
            for pose in stream:
                print(json.dumps(pose_to_dict(pose)), flush=True)
                received += 1
                if args.count and received >= args.count:
                    stream.cancel()
                    break
        elif args.command == "status":
            print(json_format.MessageToJson(client.status(), including_default_value_fields=True))
        elif args.command == "skeleton":
            print(json_format.MessageToJson(client.skeleton(), including_default_value_fields=True))
        elif args.command == "reacquire":
            client.reacquire()
        elif args.command == "background":
            learned = client.capture_background(args.frames)
            print(json.dumps({"frames_used": learned.frames_used,
                              "warnings": list(learned.warnings)}))
        elif args.command == "fit-body":
            fitted = client.fit_body(args.frames, args.apply)
            summary = {"frame_sets_used": fitted.frame_sets_used,
                       "proportions": {p.name: p.factor for p in fitted.proportions},
                       "scale": fitted.scale, "fit_seconds": fitted.fit_seconds}
            if args.apply:
                summary["body_version"] = fitted.body_version
            for line in json.dumps(summary, indent=1).splitlines():
                print("# " + line)
            sys.stdout.write(fitted.body_model_yaml)
        else:
            print(client.health())
    except client._grpc.RpcError as error:
        print("mocap_client: %s: %s" % (error.code().name, error.details()), file=sys.stderr)
        return 1
    finally:
        client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
