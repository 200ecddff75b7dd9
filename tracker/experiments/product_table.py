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

A change is judged run by run against the same runs without it (one run's error moves by tens of
millimetres from chance alone):

  tracker/experiments/product_table.py --summarize after.jsonl --against before.jsonl

prints, over the runs both files hold (the same motion, subject seed and seed), each file's MPJPE
median and mean, and the paired difference after - before: its mean, the mean's standard error and
the runs the second file has better.
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


def run_key(row):
    return row["motion"], row["subject_seed"], row["seed"]


def paired(after, before):
    """After - before over the runs both hold: (runs, mean, standard error of the mean, runs
    better, (median, mean) of each)."""
    before_by_key = {run_key(r): r for r in before}
    pairs = [(before_by_key[run_key(r)]["mpjpe_mm"], r["mpjpe_mm"]) for r in after
             if run_key(r) in before_by_key]
    if len(pairs) < 2:
        raise ValueError(f"{len(pairs)} runs in common: a paired comparison needs two or more")
    differences = [b - a for a, b in pairs]
    mean = statistics.mean(differences)
    error = statistics.stdev(differences) / len(differences) ** 0.5
    better = sum(d < 0 for d in differences)
    spread = [(statistics.median(side), statistics.mean(side))
              for side in ([a for a, _ in pairs], [b for _, b in pairs])]
    return len(pairs), mean, error, better, spread


def print_paired(after, before):
    runs, mean, error, better, ((m0, a0), (m1, a1)) = paired(after, before)
    print(f"{runs} runs in common: before median {m0:.1f} mm, mean {a0:.1f} mm; after median "
          f"{m1:.1f} mm, mean {a1:.1f} mm; after - before {mean:+.1f} +- {error:.1f} mm a run "
          f"({abs(mean) / error if error else float('inf'):.1f} standard errors), {better} of "
          f"{runs} better")


def read_rows(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


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
    parser.add_argument("--against", help="with --summarize: the same runs before a change")
    args = parser.parse_args(argv)
    if args.against and not args.summarize:
        parser.error("--against needs --summarize")
    if args.summarize:
        rows = read_rows(args.summarize)
        summarize(rows)
        if args.against:
            try:
                print_paired(rows, read_rows(args.against))
            except ValueError as e:
                parser.error(f"--against {args.against}: {e}")
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
