#!/usr/bin/env python3
"""Plots MPJPE against particle evaluations, one line per method, from the JSON lines that
experiment_table.py prints on stderr for the human experiment.

  tracker/experiments/plot_human.py [--methods M1,M2,...] docs/img/human_mpjpe.png \\
      "clean=tracker/experiments/results/human_clean.jsonl" \\
      "realistic, 2 cameras=tracker/experiments/results/human_realistic.jsonl"

Each argument is TITLE=FILE; --methods keeps only the rows of those methods. Within a file the rows are split into one panel per motion and per
camera count (when the grid varied them); the panel's title is TITLE plus those. Needs matplotlib
(Debian: python3-matplotlib).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)

METHOD_STYLE = {"factored": "o-", "factored (before the facing prior)": "o--",
                "factored (no restarts)": "o--", "factored (no hold)": "o-.",
                "factored (layers only)": "o:",
                "condensation": "s--",
                "annealed": "^:"}


def load_panels(title, path):
    panels = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line.startswith("{"):
                continue
            row = json.loads(line)
            motion = os.path.basename(row.get("motion", "")).replace(".bvh", "")
            key = (title, motion, row.get("cameras"))
            panels.setdefault(key, []).append(row)
    return panels


def main():
    argv = sys.argv[1:]
    methods = None
    if argv[:1] == ["--methods"] and len(argv) > 1:
        methods = set(argv[1].split(","))
        argv = argv[2:]
    if len(argv) < 2 or any("=" not in a for a in argv[1:]):
        sys.exit("usage: plot_human.py [--methods M1,M2,...] OUT.png TITLE=FILE.jsonl [TITLE=FILE.jsonl ...]")
    panels = {}
    for arg in argv[1:]:
        title, path = arg.split("=", 1)
        for key, rows in load_panels(title, path).items():
            rows = [row for row in rows if methods is None or row["method"] in methods]
            if rows:
                panels[key] = rows
    if not panels:
        sys.exit("plot_human.py: no result rows in the given files")
    keys = sorted(panels, key=lambda k: (k[1], str(k[2]), k[0]))
    columns = min(4, len(keys))
    rows = (len(keys) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows), squeeze=False)
    for ax, key in zip(axes.flat, keys):
        title, motion, cameras = key
        by_method = {}
        for row in panels[key]:
            by_method.setdefault(row["method"], []).append((float(row["evals"]), row["mpjpe_mm"]))
        for method, points in sorted(by_method.items()):
            points.sort()
            ax.plot([p[0] for p in points], [p[1] for p in points],
                    METHOD_STYLE.get(method, "x-"), label=method)
        ax.axhline(40, color="grey", linewidth=0.8)  # the target
        ax.set_xscale("log")
        evals = sorted({float(row["evals"]) for row in panels[key]})
        ax.set_xticks(evals)
        ax.set_xticklabels([f"{e:g}" for e in evals])
        ax.minorticks_off()
        ax.set_xlabel("evaluations per frame")
        ax.set_ylabel("MPJPE (mm, median of seeds)")
        label = f"{motion}, {title}"
        if cameras is not None:
            label += f", {cameras} cameras"
        ax.set_title(label, fontsize=9)
        ax.set_ylim(bottom=0)
        ax.grid(True, linewidth=0.3)
        ax.legend(fontsize=8)
    for ax in list(axes.flat)[len(keys):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(argv[0], dpi=90)


if __name__ == "__main__":
    main()
