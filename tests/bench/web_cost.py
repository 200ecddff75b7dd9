#!/usr/bin/python3
"""What the web view costs the daemon (docs/web.md), printed as JSON.

mocapd runs the fake walk (deploy/configs/fake-walk.yaml: 2 cameras, 780x580, 25 Hz) with its web
view on loopback. Each run starts a fresh daemon, lets it settle, and measures two phases of
SECONDS each, in alternating order from run to run so that a drift of the machine's load falls on
both:
  cpu   the daemon's CPU (utime + stime from /proc/<pid>/stat) in % of one core, with no browser
        and with one browser, whose difference is the view's cost; and the CPU of the view's own
        threads (named mocapd-web: the server, every request and event stream, the JPEG
        encoding), which the tracker's share of a loaded machine does not blur
  p99   pose latency p99 from `mocapctl bench` (capture to pose on the wire), with no browser and
        with BROWSERS of them
It reports the medians over the runs and every run's figures.

--interleaved WINDOWS measures latency alone, finer: one daemon, WINDOWS windows of SECONDS in the
order none, browsers, browsers, none, ..., every pose's latency kept. Each condition's p99 is taken
over all its poses pooled, and the difference's 95 % interval from resampling whole windows (the
machine's load drifts window by window, so the windows, not the poses, are the samples).

A browser is, by default, a client that asks what the page asks, at the page's pace (server/web/
view.js): the pose event stream, each camera's JPEG again 200 ms after the last one arrived, the
status every second. It costs the daemon what a page costs, without a browser's own rendering
competing for the cores. --chromium opens real pages instead (headless Chromium, software WebGL):
one browser process, one tab per browser.
Usage: tests/bench/web_cost.py BIN_DIR [--seconds 20] [--runs 3] [--browsers 5] [--chromium]
                               [--config FILE] [--asks poses,images,status] [--latency-only]
                               [--interleaved WINDOWS]
"""
import argparse
import http.client
import json
import os
import random
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import yaml

WALK = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "deploy",
                                    "configs", "fake-walk.yaml"))

SETTLE_S = 5  # a new daemon's tracker finds the subject; a new page loads


def free_ports():
    """Two ports free now, for the daemon's gRPC and web listeners."""
    sockets = [socket.socket() for _ in range(2)]
    for s in sockets:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in sockets]
    for s in sockets:
        s.close()
    return ports


def daemon_config(path, grpc_port, web_port):
    """The configuration at `path` on these loopback ports, its motion path made absolute."""
    with open(path) as given:
        config = yaml.safe_load(given)
    if "scene_motion" in config:
        config["scene_motion"] = os.path.normpath(os.path.join(os.path.dirname(path), config["scene_motion"]))
    config.update(listen=f"127.0.0.1:{grpc_port}", log_level="warning",
                  web={"listen": f"127.0.0.1:{web_port}"})
    return yaml.safe_dump(config)


def cpu_seconds(stat_path):
    with open(stat_path) as stat:
        name, fields = stat.read().split(" (", 1)[1].rsplit(") ", 1)
    fields = fields.split()
    return name, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime


def web_cpu_seconds(pid):
    """The CPU of the threads named mocapd-web: the view's server, all its requests and streams."""
    total = 0.0
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            name, seconds = cpu_seconds(f"/proc/{pid}/task/{task}/stat")
        except OSError:
            continue  # a thread that ended
        total += seconds if name == "mocapd-web" else 0
    return total


def cpu_percent(pid, seconds):
    """The daemon's CPU and its web threads' over `seconds`, in % of one core."""
    start = time.monotonic()
    total, web = cpu_seconds(f"/proc/{pid}/stat")[1], web_cpu_seconds(pid)
    time.sleep(seconds)
    elapsed = time.monotonic() - start
    return (100 * (cpu_seconds(f"/proc/{pid}/stat")[1] - total) / elapsed,
            100 * (web_cpu_seconds(pid) - web) / elapsed)


def bench(bin_dir, port, seconds, *flags):
    result = subprocess.run([os.path.join(bin_dir, "mocapctl"), "bench", "--seconds", str(seconds),
                             "--server", f"127.0.0.1:{port}", *flags],
                            capture_output=True, text=True, check=True)
    return json.loads(result.stdout)


def bench_p99(bin_dir, port, seconds):
    return bench(bin_dir, port, seconds)["latency_ms"]["p99"]


def p99(samples):
    ordered = sorted(samples)
    return ordered[round(0.99 * (len(ordered) - 1))]


class PageLikeClient:
    """One browser's requests, as server/web/view.js makes them, on its own threads."""

    def __init__(self, port, cameras, asks):
        self.port, self.stopping = port, threading.Event()
        self.threads = []
        if "poses" in asks:
            self.threads.append(threading.Thread(target=self.poses, daemon=True))
        if "status" in asks:
            self.threads.append(threading.Thread(target=self.status, daemon=True))
        if "images" in asks:
            self.threads += [threading.Thread(target=self.images, args=(c,), daemon=True)
                             for c in range(cameras)]
        for thread in self.threads:
            thread.start()

    def poses(self):
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=5)
        connection.request("GET", "/api/poses")
        response = connection.getresponse()
        while not self.stopping.is_set() and response.readline():
            pass
        connection.close()

    def repeat(self, path, pause_s):
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=5)
        while not self.stopping.is_set():
            try:
                connection.request("GET", path)
                connection.getresponse().read()
            except (OSError, http.client.HTTPException):
                connection.close()  # the server closed an idle keep-alive: reconnect
            self.stopping.wait(pause_s)
        connection.close()

    def images(self, camera):
        self.repeat(f"/api/camera/{camera}.jpg", 0.2)

    def status(self):
        self.repeat("/api/status", 1.0)

    def stop(self):
        self.stopping.set()
        for thread in self.threads:
            thread.join()


class ChromiumPages:
    """Real pages: one headless Chromium with a tab per browser, each loading the view."""

    def __init__(self, port, count, work):
        url = f"http://127.0.0.1:{port}/"
        self.process = subprocess.Popen(
            ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
             f"--user-data-dir={work}/profile-{port}", "--remote-debugging-port=0", *([url] * count)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)

    def stop(self):
        self.process.terminate()
        self.process.wait()


def open_browsers(args, port, count, work):
    if args.chromium and count > 0:
        return ChromiumPages(port, count, work)
    clients = [PageLikeClient(port, 2, args.asks.split(",")) for _ in range(count)]

    class Group:
        def stop(self):
            for client in clients:
                client.stop()
    return Group()


def one_run(args, work, run):
    daemon, grpc_port, web_port = start_daemon(args, work)
    figures = {}
    try:
        time.sleep(SETTLE_S)
        # Even runs measure without browsers first, odd runs with them first.
        for with_browsers in ([False, True] if run % 2 == 0 else [True, False]):
            if not with_browsers:
                if not args.latency_only:
                    figures["cpu_percent_none"], figures["web_threads_cpu_percent_none"] = \
                        cpu_percent(daemon.pid, args.seconds)
                figures["p99_ms_none"] = bench_p99(args.bin_dir, grpc_port, args.seconds)
                continue
            if not args.latency_only:
                one = open_browsers(args, web_port, 1, work)
                time.sleep(SETTLE_S)
                figures["cpu_percent_one_browser"], figures["web_threads_cpu_percent_one_browser"] = \
                    cpu_percent(daemon.pid, args.seconds)
                one.stop()
            many = open_browsers(args, web_port, args.browsers, work)
            time.sleep(SETTLE_S)
            figures["p99_ms_browsers"] = bench_p99(args.bin_dir, grpc_port, args.seconds)
            many.stop()
    finally:
        daemon.terminate()
        daemon.wait()
    if not args.latency_only:
        figures["view_cpu_percent"] = figures["cpu_percent_one_browser"] - figures["cpu_percent_none"]
    figures["p99_ms_difference"] = figures["p99_ms_browsers"] - figures["p99_ms_none"]
    return figures


def start_daemon(args, work):
    grpc_port, web_port = free_ports()
    config = os.path.join(work, "web-cost.yaml")
    with open(config, "w") as out:
        out.write(daemon_config(args.config, grpc_port, web_port))
    return subprocess.Popen([os.path.join(args.bin_dir, "mocapd"), "--config", config]), grpc_port, web_port


def interleaved(args, work):
    """Windows with and without browsers alternated on one daemon (see the module's doc)."""
    daemon, grpc_port, web_port = start_daemon(args, work)
    windows = {"none": [], "browsers": []}
    try:
        time.sleep(SETTLE_S)
        for window in range(args.interleaved):
            condition = "browsers" if window % 4 in (1, 2) else "none"
            group = open_browsers(args, web_port, args.browsers if condition == "browsers" else 0, work)
            time.sleep(SETTLE_S)
            windows[condition].append(bench(args.bin_dir, grpc_port, args.seconds, "--latencies")["latencies_ms"])
            group.stop()
            print(f"window {window} ({condition}): p99 {p99(windows[condition][-1]):.2f} ms", file=sys.stderr)
    finally:
        daemon.terminate()
        daemon.wait()

    def pooled_p99(some_windows):
        return p99([x for w in some_windows for x in w])

    rng = random.Random(1)
    resampled = sorted(pooled_p99(rng.choices(windows["browsers"], k=len(windows["browsers"]))) -
                       pooled_p99(rng.choices(windows["none"], k=len(windows["none"])))
                       for _ in range(2000))
    return {"p99_ms_none": pooled_p99(windows["none"]),
            "p99_ms_browsers": pooled_p99(windows["browsers"]),
            "p99_ms_difference": pooled_p99(windows["browsers"]) - pooled_p99(windows["none"]),
            "p99_ms_difference_95_interval": [resampled[50], resampled[1949]],
            "poses": {k: sum(len(w) for w in v) for k, v in windows.items()},
            "window_p99_ms": {k: [round(p99(w), 2) for w in v] for k, v in windows.items()}}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bin_dir")
    parser.add_argument("--seconds", type=int, default=20)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--browsers", type=int, default=5)
    parser.add_argument("--chromium", action="store_true", help="real headless Chromium pages")
    parser.add_argument("--latency-only", action="store_true",
                        help="only the p99 phases: longer --seconds for the same time")
    parser.add_argument("--asks", default="poses,images,status",
                        help="what each page-like browser asks for: a part of the page's load, to "
                             "tell which part costs what")
    parser.add_argument("--config", default=WALK, help="the daemon's configuration (default: the fake walk)")
    parser.add_argument("--interleaved", type=int, metavar="WINDOWS",
                        help="latency only: windows with and without browsers alternated on one daemon")
    args = parser.parse_args()
    if args.interleaved:
        with tempfile.TemporaryDirectory(prefix="web_cost_") as work:
            result = interleaved(args, work)
        print(json.dumps({"config": os.path.basename(args.config), "seconds": args.seconds,
                          "windows": args.interleaved, "browsers": args.browsers,
                          "clients": "chromium" if args.chromium else "page-like " + args.asks,
                          "cores": os.cpu_count(), "load_average": os.getloadavg(), **result}, indent=2))
        return
    runs = []
    with tempfile.TemporaryDirectory(prefix="web_cost_") as work:
        for run in range(args.runs):
            runs.append(one_run(args, work, run))
            print(f"run {run}: {json.dumps(runs[-1])}", file=sys.stderr)
    median = {key: statistics.median(r[key] for r in runs) for key in runs[0]}
    print(json.dumps({"config": os.path.basename(args.config), "seconds": args.seconds,
                      "runs": args.runs, "browsers": args.browsers,
                      "clients": "chromium" if args.chromium else "page-like " + args.asks,
                      "cores": os.cpu_count(), "load_average": os.getloadavg(),
                      "median": median, "all_runs": runs}, indent=2))


if __name__ == "__main__":
    main()
