#!/usr/bin/env python3
"""Runs the human tracker's product path (mocap-experiment human --scenario product) over motions,
subject seeds and seeds, keeps every run's JSON as one line of --out, and prints per motion what
the product-path issue asks for, pooled over all its runs: MPJPE median and mean, the share of
frames lost (over 100 mm), the runs with a loss longer than 25 frames, and the fitted body against
the subject (segment lengths within 3 %, girths within 10 %).

  tracker/experiments/product_table.py --motions ../shared/data/motion/*.bvh \\
      --subjects 1,2,3,4,5 --seeds 1,2,3 --jobs 2 --out product.jsonl -- --frames 200

Everything after "--" is passed to every run. Runs are independent processes, so --jobs N runs N
at once (results do not depend on it). --summarize FILE prints the table of an earlier --out.
"""
import argparse
import concurrent.futures
import json
import os
import statistics
import sys

from experiment_table import run, split_passthrough

LENGTHS = ("legs", "arms", "trunk", "head", "width")
# Results from before the body had a girth per part carry one "girth" for the whole body.
GIRTHS = ("trunk_girth", "arm_girth", "leg_girth")


def run_product(binary, motion, subject, seed, passthrough):
    return run(binary, "human", ["--motion", motion, "--scenario", "product", "--subject-seed",
                                 subject, "--seed", seed] + passthrough)


def fit_errors(run_json):
    """The fitted body's largest relative errors against the subject's: of lengths, of girths."""
    fitted, drawn = run_json.get("body_proportions"), run_json.get("subject_proportions")
    if not fitted or not drawn:
        return None
    # Both are factors on the shipped body's own (the fitted ones include the fit's scale).
    lengths = [abs(fitted[k] / drawn[k] - 1) for k in LENGTHS]
    girths = [abs(fitted[k] / drawn[k] - 1) for k in GIRTHS if k in fitted] or \
        [abs(fitted["girth"] / drawn["girth"] - 1)]
    return max(lengths), max(girths)


def summarize(rows):
    by_motion = {}
    for r in rows:
        by_motion.setdefault(r["motion"], []).append(r)
    print("| motion | runs | MPJPE median | MPJPE mean | frames lost | runs with a loss > 25 frames "
          "| fits with every length within 3 % | fits with every girth within 10 % |")
    print("|" + " --- |" * 8)
    for motion, runs in sorted(by_motion.items()):
        errors = [r["mpjpe_mm"] for r in runs]
        lost = sum(r["lost_frames"] for r in runs) / sum(r["frames"] for r in runs)
        long_losses = sum(r["longest_loss_frames"] > 25 for r in runs)
        fits = [e for e in map(fit_errors, runs) if e]
        lengths_ok = sum(e[0] <= 0.03 for e in fits)
        girth_ok = sum(e[1] <= 0.10 for e in fits)
        print(f"| {motion} | {len(runs)} | {statistics.median(errors):.1f} mm | "
              f"{statistics.mean(errors):.1f} mm | {100 * lost:.1f} % | {long_losses} | "
              f"{lengths_ok} of {len(fits)} | {girth_ok} of {len(fits)} |")


def main():
    argv, passthrough = split_passthrough(sys.argv[1:])
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", default="build/bin/mocap-experiment")
    parser.add_argument("--motions", nargs="+")
    parser.add_argument("--subjects", default="1,2,3,4,5")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", help="every run's JSON, one line each")
    parser.add_argument("--summarize", help="print the table of an earlier --out and stop")
    args = parser.parse_args(argv)
    if args.summarize:
        with open(args.summarize) as f:
            summarize([json.loads(line) for line in f if line.strip()])
        return
    if not args.motions or not args.out:
        parser.error("--motions and --out are required (or --summarize FILE)")
    for motion in args.motions:
        if not os.path.isfile(motion):
            parser.error(f"--motions: no file '{motion}'")
    runs = [(m, s, seed) for m in args.motions for s in args.subjects.split(",")
            for seed in args.seeds.split(",")]
    rows = []
    with open(args.out, "w") as out, \
            concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        jobs = [pool.submit(run_product, args.bin, m, s, seed, passthrough) for m, s, seed in runs]
        for job in concurrent.futures.as_completed(jobs):
            row = job.result()
            rows.append(row)
            out.write(json.dumps(row, sort_keys=True) + "\n")
            out.flush()
            print(f"{row['motion']} subject {row['subject_seed']} seed {row['seed']}: "
                  f"{row['mpjpe_mm']:.1f} mm", file=sys.stderr, flush=True)
    summarize(rows)


if __name__ == "__main__":
    main()
