"""The command line: python3 -m mocapd stream|status|skeleton|health|reacquire|background|fit-body.

    stream [--count N] [--joints a,b]    JSON lines, one pose a line
    status | skeleton                    JSON
    health                               SERVING, NOT_SERVING, UNKNOWN or SERVICE_UNKNOWN
    reacquire | background [--frames N]
    fit-body [--frames N] [--apply]      the fitted body model (YAML) on stdout, the figures as
                                         comments at its top
"""

import argparse
import json
import os
import sys

from mocapd.client import Client
from mocapd.pose import pose_to_dict

COMMANDS = ["stream", "status", "skeleton", "health", "reacquire", "background", "fit-body"]


def parse_arguments(argv=None, prog="python3 -m mocapd"):
    parser = argparse.ArgumentParser(prog=prog, description="Python client of mocapd")
    parser.add_argument("command", choices=COMMANDS)
    parser.add_argument("--server", default="127.0.0.1:50051")
    parser.add_argument("--token", default=os.environ.get("MOCAP_TOKEN"))
    parser.add_argument("--tls-ca", help="the daemon's certificate (PEM): connect with TLS")
    parser.add_argument("--tls-cert", help="this client's certificate (PEM), with --tls-key")
    parser.add_argument("--tls-key", help="this client's private key (PEM)")
    parser.add_argument("--stubs", help="folder of the generated stubs when not installed "
                        "(<build>/python; or set MOCAP_PY_STUBS)")
    parser.add_argument("--count", type=int, default=0, help="stream: stop after N poses")
    parser.add_argument("--joints", default="", help="stream: comma-separated joint names")
    parser.add_argument("--frames", type=int, default=0,
                        help="background: frames per camera to learn from (0: the daemon's 25); "
                        "fit-body: frame sets to fit from (0: the daemon's 5)")
    parser.add_argument("--apply", action="store_true",
                        help="fit-body: the daemon also tracks with the fitted body from then on")
    return parser.parse_args(argv)


def run(client, args):
    from google.protobuf import json_format
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
        print(json.dumps({"frames_used": learned.frames_used, "warnings": list(learned.warnings)}))
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


def main(argv=None, prog="python3 -m mocapd"):
    args = parse_arguments(argv, prog)
    try:
        client = Client(args.server, args.token, args.tls_ca, args.stubs, args.tls_cert,
                        args.tls_key)
    except (ImportError, ValueError) as error:
        print("%s: %s" % (prog, error), file=sys.stderr)
        return 2
    try:
        run(client, args)
    except client.RpcError as error:
        print("%s: %s: %s" % (prog, error.code().name, error.details()), file=sys.stderr)
        return 1
    finally:
        client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
