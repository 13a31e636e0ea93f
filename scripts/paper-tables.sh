#!/usr/bin/env bash
# Reproduces the paper's Table 1 (constraints and error) and Table 2 (running time) on its own
# models at its volume sizes, with the defaults and with the constraint budget set to the
# paper's count, and prints the error against the number of constraints of every iteration
# (the trade-off curve behind the paper's single point).
#
# Usage: scripts/paper-tables.sh [MODELS_DIR]   (default ../shared/models)
set -euo pipefail
cd "$(dirname "$0")/.."
models=${1:-../shared/models}
cargo build --release --quiet --bin implicitize
bin=target/release/implicitize
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# name, file, --resolution (the paper's volume by its longest axis), the paper's constraints,
# iterations, max error (voxels) and total time (minutes).
runs=(
  "bunny bunny.obj 220 515 20 4 113.30"
  "horse horse.ply 337 679 22 5 170.49"
  "triceratops triceratops.obj 320 503 22 3 82.78"
)
echo "| model | volume | budget | iterations | zero | interior | exterior | E (voxels) | E sub-voxel | RMS | time (s) | paper: constraints, iterations, E, time |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for run in "${runs[@]}"; do
  read -r name file resolution paper_n paper_it paper_e paper_min <<<"$run"
  for budget in default "$paper_n"; do
    args=()
    [[ $budget == default ]] || args=(--max-constraints "$budget")
    "$bin" fit "$models/$file" --resolution "$resolution" "${args[@]}" --quiet \
      -o "$work/$name-$budget.json" --report "$work/$name-$budget-report.json"
    python3 - "$work/$name-$budget-report.json" "$name" "$budget" "$paper_n" "$paper_it" "$paper_e" "$paper_min" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
name, budget, pn, pit, pe, pmin = sys.argv[2:]
c = r["constraints"]
best = r["per_iteration"][r["best_iteration"] - 1]
vol = " x ".join(map(str, r["dims"]))
print(f"| {name} | {vol} | {budget} | {r['iterations']} | {c['boundary']} | {c['interior']} | {c['exterior']} "
      f"| {r['max_error_voxels']:.2f} | {best['max_error_subvoxel_voxels']:.2f} | {r['rms_error_voxels']:.2f} "
      f"| {r['timings_s']['total']:.1f} | {pn}, {pit}, {pe}, {float(pmin) * 60:.0f} s |")
PY
  done
done
echo
echo "Error against constraints, every iteration of the default runs (constraints: E voxels):"
for run in "${runs[@]}"; do
  read -r name _ <<<"$run"
  python3 - "$work/$name-default-report.json" "$name" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
points = [f"{i['constraints']['boundary'] + i['constraints']['interior'] + i['constraints']['exterior']}: {i['max_error_voxels']:.2f}" for i in r["per_iteration"]]
print(f"- {sys.argv[2]}: " + ", ".join(points))
PY
done
