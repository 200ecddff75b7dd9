#!/usr/bin/python3
"""Recording size and replay accuracy per image mode (docs/recording.md), printed as JSON.

For each mode (lossless, compressed, none) and each run: mocapd records the fake walk
(deploy/configs/fake-walk.yaml: 2 cameras, 780x580, 25 Hz) for SECONDS, then replays the session
at the recorded pace while `mocapctl stream` collects each pose's error against the recorded
truth. Per mode it reports the medians over the runs of:
  mb_per_recorded_s  session bytes / (frame sets / 25 Hz): what a second of recording costs
  mb_per_wall_s      session bytes / wall time from start to stop: what the disk had to take
  replay_error_mm    the median error of the replayed poses after the session's first second
                     (the tracker finding the subject), against the truth
Usage: tests/bench/recording_modes.py BIN_DIR [--seconds 10] [--runs 3] [--modes a,b,c]
"""
import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WALK = os.path.join(SOURCE, "deploy", "configs", "fake-walk.yaml")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def walk_config(extra):
    """fake-walk.yaml with its motion path made absolute and `extra` lines for its other keys."""
    lines = []
    for line in open(WALK):
        if line.startswith("scene_motion:"):
            path = line.split(":", 1)[1].strip()
            line = "scene_motion: " + os.path.normpath(os.path.join(os.path.dirname(WALK), path)) + "\n"
        if line.startswith("listen:") or line.startswith("log_level:"):
            continue
        lines.append(line)
    return "".join(lines) + "".join(line + "\n" for line in extra)


def mocapctl(bin_dir, port, *args, check=True):
    result = subprocess.run([os.path.join(bin_dir, "mocapctl"), *args, "--server", f"127.0.0.1:{port}"],
                            capture_output=True, text=True)
    if check and result.returncode != 0:
        raise RuntimeError(f"mocapctl {' '.join(args)}: {result.stderr.strip()}")
    return result


def session_bytes(path):
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files)


def committed_sets(path):
    with open(os.path.join(path, "sets.csv")) as sets:
        return sum(1 for _ in sets) - 1


def record(bin_dir, work, mode, seconds, name):
    port = free_port()
    config = os.path.join(work, f"record-{name}.yaml")
    with open(config, "w") as out:
        out.write(walk_config([f"listen: 127.0.0.1:{port}", "log_level: warning",
                               "web: {enabled: false}", f"recording_directory: {work}",
                               f"recording: {{images: {mode}, min_free_mb: 0}}"]))
    daemon = subprocess.Popen([os.path.join(bin_dir, "mocapd"), "--config", config])
    try:
        give_up = time.time() + 30
        while mocapctl(bin_dir, port, "record", "start", name, check=False).returncode != 0:
            if time.time() > give_up:
                raise RuntimeError("the daemon did not start recording")
            time.sleep(0.2)
        started = time.time()
        time.sleep(seconds)
        mocapctl(bin_dir, port, "record", "stop")
        wall = time.time() - started
    finally:
        daemon.terminate()
        daemon.wait()
    session = os.path.join(work, name)
    size, sets = session_bytes(session), committed_sets(session)
    return session, {"bytes": size, "frame_sets": sets, "mb_per_recorded_s": size / 1e6 / (sets / 25.0),
                     "mb_per_wall_s": size / 1e6 / wall}


def replay_error(bin_dir, work, session):
    port = free_port()
    config = os.path.join(work, "replay.yaml")
    with open(config, "w") as out:
        # As deploy/configs/replay.yaml: the session's body and settings. A session without images
        # replays its silhouettes as images, which the threshold keeps.
        out.write("cameras: [{driver: fake}, {driver: fake}]\ntracker: {threads: 1}\n"
                  f"listen: 127.0.0.1:{port}\nlog_level: warning\nweb: {{enabled: false}}\n"
                  "before_background: threshold\n")
    daemon = subprocess.Popen([os.path.join(bin_dir, "mocapd"), "--config", config, "--replay", session])
    errors = []
    try:
        stream = None
        while stream is None and daemon.poll() is None:
            attempt = subprocess.Popen([os.path.join(bin_dir, "mocapctl"), "stream", "--server", f"127.0.0.1:{port}"],
                                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            first = attempt.stdout.readline()
            if first:
                stream, lines = attempt, [first]
            else:
                attempt.wait()
                time.sleep(0.05)
        if stream:
            lines += stream.stdout.readlines()  # until the replay ends and the daemon exits
            stream.wait()
            first_frame = None
            for line in lines:
                pose = json.loads(line)
                if first_frame is None:
                    first_frame = pose["frame"]
                if pose["frame"] >= first_frame + 25 and "reference_error_mm" in pose:
                    errors.append(pose["reference_error_mm"])
    finally:
        daemon.wait()
    return statistics.median(errors) if errors else None, len(errors)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bin_dir")
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--modes", default="lossless,compressed,none")
    args = parser.parse_args()
    work = tempfile.mkdtemp(prefix="recording_modes_")
    results = {}
    try:
        for mode in args.modes.split(","):
            runs = []
            for run in range(args.runs):
                session, figures = record(args.bin_dir, work, mode, args.seconds, f"{mode}-{run}")
                figures["replay_error_mm"], figures["replayed_poses"] = replay_error(args.bin_dir, work, session)
                shutil.rmtree(session)
                runs.append(figures)
                print(f"{mode} run {run}: {json.dumps(figures)}", file=sys.stderr)
            summary = {key: statistics.median(r[key] for r in runs if r[key] is not None)
                       for key in ("mb_per_recorded_s", "mb_per_wall_s", "replay_error_mm")}
            results[mode] = {"median": summary, "runs": runs}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps({"seconds": args.seconds, "runs": args.runs, "modes": results}, indent=2))


if __name__ == "__main__":
    main()
