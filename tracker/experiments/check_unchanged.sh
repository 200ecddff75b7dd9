#!/usr/bin/env bash
# Runs the experiments that pin the tracker's behaviour and prints one hash per run, with the
# timing fields removed (they vary from run to run). Compare the output before and after a change.
set -euo pipefail
bin=${1:-build/bin}
motion=${MOCAP_SHARED_DIR:-../shared}/data/motion
strip() { /usr/bin/python3 -c 'import json,sys
d=json.load(sys.stdin)
def clean(o):
    if isinstance(o,dict): return {k:clean(v) for k,v in o.items() if "second" not in k and not k.endswith("_ms")}
    if isinstance(o,list): return [clean(v) for v in o]
    return o
print(json.dumps(clean(d),sort_keys=True))'; }
run() { printf '%s  %s\n' "$("$bin/mocap-experiment" "$@" | strip | sha256sum | cut -c1-16)" "$*"; }
for s in 1 2; do run hand --seed $s; done
for m in walk hop; do
  f=$(ls "$motion"/cmu_131_0*_"$m".bvh)
  for s in 1 2; do run human --motion "$f" --frames 60 --seed $s; done
done
walk=$motion/cmu_131_01_walk.bvh
run human --motion "$walk" --frames 60 --seed 1 --tracked-body fit
run human --motion "$walk" --frames 60 --seed 1 --start-offset acquire
run human --motion "$walk" --frames 60 --seed 1 --noise realistic
