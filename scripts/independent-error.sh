#!/usr/bin/env bash
# Measures a fit's error independently of the fit's own voxel metrics: fits the mesh with the
# defaults, polygonizes the model on the fit's grid, samples 50,000 points on each surface and
# measures their distance to the other surface with libigl (exact point-to-triangle distance),
# in voxels of the fit's grid.
#
# Usage: scripts/independent-error.sh [MESH] [RESOLUTION]
#   default: ../shared/models/bunny.obj at 220 (the paper's volume).
# Needs Python 3 for libigl and trimesh (made by ../shared/bench/setup-peers.sh); the project's
# own tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-../shared/models/bunny.obj}
resolution=${2:-220}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --bin implicitize
./target/release/implicitize fit "$mesh" --resolution "$resolution" --quiet \
  -o "$work/model.json" --report "$work/report.json" --mesh-out "$work/surface.ply"

"$python" - "$mesh" "$work" <<'PY'
import json, sys
import numpy as np
import trimesh

sys.path.insert(0, "scripts")
from surface_distance import distances

mesh_path, work = sys.argv[1:]
report = json.load(open(f"{work}/report.json"))
voxel = report["voxel_size"]
goal = trimesh.load(mesh_path, force="mesh")
fitted = trimesh.load(f"{work}/surface.ply", force="mesh")

mesh_to_implicit = distances(goal, fitted, voxel)
implicit_to_mesh = distances(fitted, goal, voxel)
print(f"{mesh_path}: E {report['max_error_voxels']:.2f} voxels (fit's own measure), "
      f"{sum(report['constraints'].values())} constraints")
for name, d in [("mesh -> implicit", mesh_to_implicit), ("implicit -> mesh", implicit_to_mesh)]:
    print(f"  {name}: max {d.max():.2f}, 99.9% {np.percentile(d, 99.9):.2f}, "
          f"mean {d.mean():.2f} voxels")
PY
