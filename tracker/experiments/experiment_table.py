#!/usr/bin/env python3
"""Runs a mocap-experiment over a grid of flag values and seeds; prints the median of each metric
per grid point as JSON lines (stderr, as they finish) and as a Markdown table (stdout).

  tracker/experiments/experiment_table.py hand --grid method=factored,condensation \\
      --grid evals=375,750,1500 --seeds 1,2,3,4,5 --metrics mean_relative_error,forefinger_tip_relative_error \\
      -- --frames 200 --threads 1

Everything after "--" is passed to every run. Runs are independent processes, so --jobs N runs N
at once (results do not depend on it; only seconds_per_frame does).
"""
import argparse
import concurrent.futures
import itertools
import json
import statistics
import subprocess
import sys


def run(binary, experiment, flags):
    out = subprocess.run([binary, experiment] + flags, check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def split_passthrough(argv):
    """The script's own arguments, and those after "--" for every run."""
    if "--" not in argv:
        return argv, []
    return argv[:argv.index("--")], argv[argv.index("--") + 1:]


def main():
    argv, passthrough = split_passthrough(sys.argv[1:])
    parser = argparse.ArgumentParser()
    parser.add_argument("experiment")
    parser.add_argument("--bin", default="build/bin/mocap-experiment")
    parser.add_argument("--grid", action="append", default=[], help="flag=v1,v2,...")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--metrics", required=True)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)

    names = [g.split("=", 1)[0] for g in args.grid]
    values = [g.split("=", 1)[1].split(",") for g in args.grid]
    metrics = args.metrics.split(",")
    points = list(itertools.product(*values))
    seeds = args.seeds.split(",")
    jobs = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for point in points:
            for seed in seeds:
                flags = [f for n, v in zip(names, point) for f in ("--" + n, v)]
                flags += ["--seed", seed] + passthrough
                jobs[(point, seed)] = pool.submit(run, args.bin, args.experiment, flags)
        rows = []
        for point in points:
            results = [jobs[(point, seed)].result() for seed in seeds]
            row = dict(zip(names, point))
            for m in metrics:
                vals = [r[m] for r in results if r.get(m) is not None]
                row[m] = statistics.median(vals) if vals else None
                row[m + "_per_seed"] = [r.get(m) for r in results]
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    print("| " + " | ".join(names + metrics) + " |")
    print("|" + " --- |" * (len(names) + len(metrics)))
    for row in rows:
        cells = [str(row[n]) for n in names]
        cells += ["—" if row[m] is None else f"{row[m]:.4g}" for m in metrics]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
