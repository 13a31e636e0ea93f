#!/usr/bin/env bash
# The spread of the default fit over seeds, on the paper's models at its volume sizes, with the
# start at half the resolution (the default) and without it (--full-resolution): constraints,
# E and time of each run, and the means.
#
# Usage: scripts/seeds.sh [SEEDS] [MODELS_DIR]   (default 4 seeds, ../shared/models)
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-4}
models=${2:-../shared/models}
cargo build --release --quiet --bin implicitize
bin=target/release/implicitize
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

for run in "bunny bunny.obj 220" "horse horse.ply 337" "triceratops triceratops.obj 320"; do
  read -r name file resolution <<<"$run"
  for mode in coarse-start full-resolution; do
    flags=()
    [[ $mode == full-resolution ]] && flags=(--full-resolution)
    for seed in $(seq 1 "$seeds"); do
      "$bin" fit "$models/$file" --resolution "$resolution" --seed "$seed" "${flags[@]}" --quiet \
        -o "$work/model.json" --report "$work/$name-$mode-$seed.json"
    done
  done
done
python3 - "$work" "$seeds" <<'PY'
import json, sys
work, seeds = sys.argv[1], int(sys.argv[2])
print("| model | start | constraints per seed | mean | E per seed | time per seed (s) | mean time (s) |")
print("|---|---|---|---|---|---|---|")
for name in ["bunny", "horse", "triceratops"]:
    for mode in ["coarse-start", "full-resolution"]:
        rs = [json.load(open(f"{work}/{name}-{mode}-{s}.json")) for s in range(1, seeds + 1)]
        n = [sum(r["constraints"].values()) for r in rs]
        e = [r["max_error_voxels"] for r in rs]
        t = [r["timings_s"]["total"] for r in rs]
        print(f"| {name} | {mode} | {', '.join(map(str, n))} | {sum(n) / len(n):.0f} "
              f"| {', '.join(f'{x:.2f}' for x in e)} | {', '.join(f'{x:.1f}' for x in t)} "
              f"| {sum(t) / len(t):.1f} |")
PY
