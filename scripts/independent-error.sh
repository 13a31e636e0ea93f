#!/usr/bin/env bash
# Measures a fit's error independently of the fit's own measures: fits the mesh with the
# defaults, polygonizes the model on the fit's grid (--mesh-out), spreads SAMPLES points
# (default 1,000,000) by area over each surface (stratified, numpy; scripts/surface_distance.py)
# and measures their distance to the other surface with libigl (exact point-to-triangle
# distance), in voxels of the fit's grid; prints them beside the report's own `mesh_distance`
# (100,000 points each way, spread and measured by implicitize) and the difference.
#
# Usage: [IMPLICITIZE=BINARY] [SAMPLES=N] scripts/independent-error.sh [MESH] [RESOLUTION]
#   default: ../shared/models/bunny.obj at 220 (the paper's volume), the release build.
# Needs Python 3 for libigl and trimesh (made by ../shared/bench/setup-peers.sh); the project's
# own tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-../shared/models/bunny.obj}
resolution=${2:-220}
samples=${SAMPLES:-1000000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python=$(bash ../shared/bench/setup-peers.sh)
if [ -z "${IMPLICITIZE:-}" ]; then
  cargo build --release --quiet --bin implicitize
  IMPLICITIZE=./target/release/implicitize
fi
"$IMPLICITIZE" fit "$mesh" --resolution "$resolution" --quiet \
  -o "$work/model.json" --report "$work/report.json" --mesh-out "$work/surface.ply"

"$python" - "$mesh" "$work" "$samples" <<'PY'
import json, sys
import numpy as np
import trimesh

sys.path.insert(0, "scripts")
from surface_distance import distances

mesh_path, work, samples = sys.argv[1:]
report = json.load(open(f"{work}/report.json"))
voxel = report["voxel_size"]
goal = trimesh.load(mesh_path, force="mesh")
fitted = trimesh.load(f"{work}/surface.ply", force="mesh")

print(f"{mesh_path}: E {report['max_error_voxels']:.2f} voxels (fit's own measure), "
      f"{sum(report['constraints'].values())} constraints; voxels, libigl on {int(samples):,} "
      "samples | the report's mesh_distance | difference")
ways = [("mesh -> implicit", "mesh_to_model", goal, fitted),
        ("implicit -> mesh", "model_to_mesh", fitted, goal)]
for name, key, source, target in ways:
    d = distances(source, target, voxel, int(samples))
    igl = [d.max(), np.percentile(d, 99.9), d.mean()]
    own = [report["mesh_distance"][key][k] for k in ("max", "p99.9", "mean")]
    row = lambda v: ", ".join(f"{x:.3f}" for x in v)
    print(f"  {name}: max, 99.9%, mean: {row(igl)} | {row(own)} | "
          f"{row(o - i for o, i in zip(own, igl))}")
PY
