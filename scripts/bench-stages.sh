#!/usr/bin/env bash
# Times each stage of implicitize against the Python peers (libigl, scipy, scikit-image) on the
# same mesh and grid, in one run, and prints a table with the ratios.
#
# Usage: scripts/bench-stages.sh [MESH] [RESOLUTION]
#   default: ../shared/models/bunny.obj at 220 (the paper's 176 x 220 x 218 volume).
# Needs Python 3 for the peers (made by ../shared/bench/setup-peers.sh); the project's own
# tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-../shared/models/bunny.obj}
resolution=${2:-220}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --bin implicitize --example stages

# The grid implicitize places around the mesh; the peers get exactly the same dims.
./target/release/implicitize sdf "$mesh" --resolution "$resolution" -o "$work/ours.npy" --quiet
read -r nx ny nz < <("$python" -c "import json,sys; print(*json.load(open(sys.argv[1]))['dims'])" "$work/ours.json")

# Whole processes, voxelization plus signed distance, side by side.
time_process() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }
ours_process=$(time_process ./target/release/implicitize sdf "$mesh" --resolution "$resolution" -o "$work/ours.npy" --quiet)
peer_process=$(time_process "$python" ../shared/bench/peers.py sdf "$mesh" "$work/ours.json" "$work/peer.npy")

"$python" ../shared/bench/peers.py stages "$mesh" "$nx" "$ny" "$nz" > "$work/peer.json"
./target/release/examples/stages "$mesh" "$nx" "$ny" "$nz" > "$work/ours-stages.json"

"$python" - "$work" "$mesh" "$ours_process" "$peer_process" <<'PY'
import json, sys
import numpy as np
work, mesh, ours_process, peer_process = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
peer = json.load(open(f"{work}/peer.json"))
ours = json.load(open(f"{work}/ours-stages.json"))
a, b = np.load(f"{work}/ours.npy"), np.load(f"{work}/peer.npy")
far = (np.abs(a) > 1.5) | (np.abs(b) > 1.5)
agree = np.mean((a[far] > 0) == (b[far] > 0)) * 100
dims = " x ".join(map(str, peer["grid"]))
print(f"{mesh} on {dims} voxels\n")
print(f"| stage | implicitize (s) | peer (s) | peer / implicitize |")
print(f"|---|---|---|---|")
rows = [
    ("voxelize + signed distance, whole process", ours_process, peer_process),
    ("inside/outside (peer: libigl fast winding number)", ours["voxelize_s"], peer["inside_fast_winding_number_s"]),
    ("signed distance (peer: scipy EDT x 2)", ours["signed_distance_s"], peer["signed_distance_s"]),
    ("polygonize (peer: scikit-image marching cubes)", ours["polygonize_s"], peer["marching_cubes_s"]),
    ("solve 700 constraints (peer: scipy RBFInterpolator)", ours["rbf_fit_700_s"], peer["rbf_fit_700_s"]),
    ("evaluate 700 constraints at 500k points", ours["rbf_eval_700_at_500k_s"], peer["rbf_eval_700_at_500k_s"]),
]
for name, o, p in rows:
    print(f"| {name} | {o:.3f} | {p:.3f} | {p / o:.1f}x |")
print(f"\ninside/outside agreement with the peer, voxels more than one voxel from either surface: {agree:.3f}%")
PY
