"""Client: one channel to mocapd, its RPCs as methods, the pose stream as Pose objects."""

from mocapd import stubs
from mocapd.pose import Pose

# Keeps a slow reader near live: without BDP probing and with a small per-stream window, only a
# few poses wait in this client's buffers; the daemon drops the older ones and says how many in
# Pose.missed_before (see clients/mocapctl/daemon_client.h).
NEAR_LIVE_CHANNEL_OPTIONS = [
    ("grpc.http2.bdp_probe", 0),
    ("grpc.http2.lookahead_bytes", 16 * 1024),
]


class Client:
    """A connection to mocapd at `server` ("host:port"). `token`: the daemon's bearer token;
    `tls_ca`: the daemon's certificate (PEM) to trust, for TLS; `tls_cert` and `tls_key`: this
    client's certificate and key (PEM), for a daemon that asks for one; `stubs_dir`: where the
    generated stubs are when they are not installed (a build's <build>/python).
    Usable as a context manager; close() ends the channel and every stream on it."""

    def __init__(self, server="127.0.0.1:50051", token=None, tls_ca=None, stubs_dir=None,
                 tls_cert=None, tls_key=None):
        import grpc
        self._grpc = grpc
        self.pb, pb_grpc = stubs.load(stubs_dir)
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

    @property
    def RpcError(self):
        """grpc.RpcError: what every method raises when the daemon refuses or cannot be reached."""
        return self._grpc.RpcError

    def close(self):
        self._channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def poses(self, joints=None, seconds=None):
        """Yields a Pose for each pose the daemon publishes, until it ends the stream or, with
        `seconds`, until that many seconds have passed. `joints`: the joint names to receive
        (default all). Leaving the loop (break, or the generator being closed or collected)
        cancels the stream."""
        stream = self.stream_poses(joints, timeout=seconds)
        try:
            for message in stream:
                yield Pose(message)
        except self._grpc.RpcError as error:
            if seconds is None or error.code() != self._grpc.StatusCode.DEADLINE_EXCEEDED:
                raise
        finally:
            stream.cancel()

    def stream_poses(self, joints=None, timeout=None):
        """The raw stream of mocap.v1.Pose messages; cancel() it to stop. `timeout`: seconds until
        the stream ends with DEADLINE_EXCEEDED."""
        request = self.pb.StreamPosesRequest(joints=joints or [])
        return self._stub.StreamPoses(request, metadata=self._metadata, timeout=timeout)

    def status(self):
        """The daemon's status (mocap.v1.Status): cameras, rates, drops, latency, tracking."""
        return self._stub.GetStatus(self.pb.GetStatusRequest(), metadata=self._metadata)

    def skeleton(self):
        """The tracked skeleton (mocap.v1.Skeleton): segments, DOFs (the order of Pose.dofs) and
        points (the joints' names)."""
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

    def health(self, service="", timeout=5):
        """grpc.health.v1.Health/Check without its stubs (Debian ships none): the request is
        HealthCheckRequest{service}, the reply HealthCheckResponse{status}, both tiny enough to
        encode by hand. Returns "SERVING", "NOT_SERVING", "UNKNOWN" or "SERVICE_UNKNOWN"."""
        name = service.encode()
        request = (b"\x0a" + bytes([len(name)]) + name) if name else b""
        check = self._channel.unary_unary("/grpc.health.v1.Health/Check",
                                          request_serializer=lambda raw: raw,
                                          response_deserializer=lambda raw: raw)
        reply = check(request, timeout=timeout)
        value = reply[1] if len(reply) >= 2 and reply[0] == 0x08 else 0
        return {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}.get(value, "UNKNOWN")
