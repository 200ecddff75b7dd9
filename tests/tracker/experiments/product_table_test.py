"""product_table.py's paired comparison: runs matched by motion, subject seed and seed, the
difference's mean and standard error, the runs better, and the errors it refuses with."""
import json
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(sys.argv.pop(1), "tracker", "experiments", "product_table.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
import product_table  # noqa: E402


def row(subject, seed, mpjpe, motion="walk.bvh"):
    return {"motion": motion, "subject_seed": subject, "seed": seed, "mpjpe_mm": mpjpe}


class PairedTest(unittest.TestCase):
    def test_runs_are_matched_by_motion_subject_and_seed(self):
        before = [row(1, 1, 100), row(1, 2, 120), row(2, 1, 90), row(3, 1, 500)]
        # Out of order, one run only in each file: the unmatched ones are left out.
        after = [row(2, 1, 100), row(1, 2, 100), row(1, 1, 90), row(4, 1, 10)]
        runs, mean, error, better, spread = product_table.paired(after, before)
        self.assertEqual(runs, 3)
        # Differences -10, -20 and +10.
        self.assertAlmostEqual(mean, -20 / 3)
        deviations = [-10 + 20 / 3, -20 + 20 / 3, 10 + 20 / 3]
        sd = (sum(d * d for d in deviations) / 2) ** 0.5
        self.assertAlmostEqual(error, sd / 3 ** 0.5)
        self.assertEqual(better, 2)
        self.assertEqual(spread, [(100, 310 / 3), (100, 290 / 3)])

    def test_another_motion_is_another_run(self):
        before = [row(1, 1, 100, "walk.bvh"), row(1, 2, 100, "walk.bvh")]
        after = [row(1, 1, 50, "hop.bvh"), row(1, 2, 50, "hop.bvh")]
        with self.assertRaisesRegex(ValueError, "0 runs in common"):
            product_table.paired(after, before)

    def test_the_command_prints_the_comparison_and_names_bad_use(self):
        with tempfile.TemporaryDirectory() as work:
            files = {}
            for name, rows in (("before", [row(1, 1, 100), row(1, 2, 120)]),
                               ("after", [row(1, 1, 90), row(1, 2, 100)])):
                files[name] = os.path.join(work, name + ".jsonl")
                with open(files[name], "w") as f:
                    for r in rows:
                        f.write(json.dumps(dict(r, lost_frames=0, frames=200,
                                                longest_loss_frames=0)) + "\n")
            done = subprocess.run([sys.executable, SCRIPT, "--summarize", files["after"],
                                   "--against", files["before"]],
                                  capture_output=True, text=True, check=True)
            self.assertIn("after - before -15.0 +- 5.0 mm a run", done.stdout)
            self.assertIn("2 of 2 better", done.stdout)
            refused = subprocess.run([sys.executable, SCRIPT, "--against", files["before"]],
                                     capture_output=True, text=True)
            self.assertNotEqual(refused.returncode, 0)
            self.assertIn("--against needs --summarize", refused.stderr)


if __name__ == "__main__":
    unittest.main()
