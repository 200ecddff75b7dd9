#!/usr/bin/env python3
"""Plots the human step's cost curves (step time against evaluations, cameras and threads) from
tracker_bench's JSON, one panel each, medians of the repetitions.

  build/bin/tracker_bench --benchmark_filter=BM_HumanStepCost --benchmark_repetitions=5 \\
      --benchmark_report_aggregates_only=true --benchmark_format=json > cost.json
  tracker/experiments/plot_cost.py cost.json docs/img/step_cost.png

Each point of the benchmark varies one of evals, cameras and threads from 2000 evaluations,
2 cameras, 1 thread. Needs matplotlib (Debian: python3-matplotlib).
"""
import json
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)

BASE = {"evals": 2000, "cameras": 2, "threads": 1}


def medians(path):
    """{(evals, cameras, threads): median step in ms} from the benchmark's aggregates."""
    points = {}
    for row in json.load(open(path))["benchmarks"]:
        if row.get("aggregate_name") != "median" or not row["name"].startswith("BM_HumanStepCost"):
            continue
        args = dict(re.findall(r"(evals|cameras|threads):(\d+)", row["name"]))
        key = tuple(int(args[k]) for k in ("evals", "cameras", "threads"))
        scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[row["time_unit"]]
        points[key] = row["real_time"] * scale
    return points


def curve(points, axis):
    index = list(BASE).index(axis)
    rows = [(key[index], ms) for key, ms in points.items()
            if all(key[i] == BASE[k] for i, k in enumerate(BASE) if k != axis)]
    return sorted(rows)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    points = medians(sys.argv[1])
    if not points:
        sys.exit(f"{sys.argv[1]}: no BM_HumanStepCost medians (run with --benchmark_repetitions)")
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    labels = {"evals": "evaluations per step", "cameras": "cameras (780x580)",
              "threads": "threads"}
    for ax, axis in zip(axes, BASE):
        xs, ys = zip(*curve(points, axis))
        ax.plot(xs, ys, "o-")
        for x, y in zip(xs, ys):
            ax.annotate(f"{y:.1f}", (x, y), textcoords="offset points", xytext=(0, 6),
                        ha="center", fontsize=8)
        ax.set_xlabel(labels[axis])
        if axis == "evals":
            ax.set_xscale("log", base=2)
        ax.set_xticks(xs, [str(x) for x in xs])
        ax.set_ylabel("step (ms)")
        ax.set_ylim(bottom=0)
        others = ", ".join(f"{BASE[k]} {k if BASE[k] != 1 else k[:-1]}" for k in BASE if k != axis)
        ax.set_title(f"the defaults; {others}", fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=100)


if __name__ == "__main__":
    main()
