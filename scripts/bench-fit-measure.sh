#!/usr/bin/env bash
# Whole-process time of the default fit of the paper's models by two builds of implicitize,
# run alternately (A, B, A, B, ...) so that both see the same load: what the fit's own measure
# against the mesh (the report's `mesh_distance`) costs.
#
# Usage: scripts/bench-fit-measure.sh BEFORE_BINARY AFTER_BINARY [ROUNDS] [MESH[@RESOLUTION]...]
#   default: 3 rounds of ../shared/models/{bunny.obj,horse.ply,triceratops.obj} at the default
#   resolution; MESH@R fits at --resolution R.
# Prints one line a run (model, build, wall-clock and CPU seconds) and the medians: on a shared
# machine the CPU time is the steadier of the two.
set -euo pipefail
cd "$(dirname "$0")/.."
before=$1 after=$2 rounds=${3:-3}
shift $(($# < 3 ? $# : 3))
models=("$@")
[ ${#models[@]} -gt 0 ] || models=(../shared/models/bunny.obj ../shared/models/horse.ply ../shared/models/triceratops.obj)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Prints the wall-clock and the CPU (user + system) seconds of one fit.
run() {
  local mesh=${2%@*} flags=()
  [[ $2 == *@* ]] && flags=(--resolution "${2##*@}")
  /usr/bin/time -f "%e %U %S" -o "$work/time" "$1" fit "$mesh" "${flags[@]}" -o "$work/model.json" --quiet
  awk '{printf "%.2f %.2f", $1, $2 + $3}' "$work/time"
}

for model in "${models[@]}"; do
  name=$(basename "${model%@*}")
  name=${name%.*}
  [[ $model == *@* ]] && name+="@${model##*@}"
  for _ in $(seq "$rounds"); do
    for build in before after; do
      binary=${!build}
      echo "$name $build $(run "$binary" "$model")"
    done
  done
done | tee "$work/runs"
echo "medians (model: wall before, after, ratio; CPU before, after, ratio):"
python3 - "$work/runs" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    name, build, wall, cpu = line.split()
    runs.setdefault(name, {}).setdefault(build, []).append((float(wall), float(cpu)))
for name, builds in runs.items():
    row = []
    for k in (0, 1):
        b, a = (statistics.median(r[k] for r in builds[w]) for w in ("before", "after"))
        row.append(f"{b:.2f} {a:.2f} {a / b:.3f}")
    print(f"{name}: {'; '.join(row)}")
PY
