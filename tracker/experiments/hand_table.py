#!/usr/bin/env python3
"""Runs the simulated hand experiment over seeds, methods and budgets and prints medians as JSON
and as a Markdown table. Usage:
  tracker/experiments/hand_table.py [--bin build/bin/mocap-experiment] [--seeds 1,2,3,4,5]
      [--evals 375,750,1500] [--methods factored,condensation] [--frames 200] [other mocap-experiment flags]
"""
import argparse
import json
import statistics
import subprocess
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", default="build/bin/mocap-experiment")
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--evals", default="375,750,1500")
    parser.add_argument("--methods", default="factored,condensation")
    parser.add_argument("--frames", default="200")
    args, extra = parser.parse_known_args()  # anything else goes to every run
    rows = []
    for evals in args.evals.split(","):
        for method in args.methods.split(","):
            runs = []
            for seed in args.seeds.split(","):
                cmd = [args.bin, "hand", "--method", method, "--evals", evals, "--seed", seed,
                       "--frames", args.frames] + extra
                out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
                runs.append(json.loads(out))
            med = lambda key: statistics.median(r[key] for r in runs)
            rows.append({
                "method": method, "evals": int(evals), "seeds": args.seeds,
                "evals_per_frame": med("evals_per_frame"),
                "mean_relative_error": med("mean_relative_error"),
                "forefinger_tip_relative_error": med("forefinger_tip_relative_error"),
                "seconds_per_frame": med("seconds_per_frame"),
                "per_seed_mean": [round(r["mean_relative_error"], 4) for r in runs],
            })
            print(json.dumps(rows[-1]), file=sys.stderr)
    print(json.dumps(rows, indent=1))
    print("\n| evaluations | method | mean relative error | forefinger tip | s/frame |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['evals']} | {r['method']} | {100 * r['mean_relative_error']:.1f} % | "
              f"{100 * r['forefinger_tip_relative_error']:.1f} % | {r['seconds_per_frame'] * 1000:.2f} ms |")


if __name__ == "__main__":
    main()
