#!/usr/bin/env bash
# Polygonization speed against scikit-image's marching cubes, on the same volumes in the
# same run: the signed distance of a few tori and spheres (written by the polygonize bench)
# and, when the peer tools and the model are there, the bunny's signed distance (by the
# peer's `peers.py sdf`), both at 176 x 220 x 218. Prints a Markdown table; times are the best
# of REPEAT runs (default 5) of each, after one warm-up.
#
# Usage: scripts/bench-polygonize.sh
# Environment: PYTHON (a Python with numpy and scikit-image; default the peers venv),
#   PEERS (peers.py), BUNNY (the bunny mesh), REPEAT.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-/tmp/implicitize-peers/bin/python}
PEERS=${PEERS:-../shared/bench/peers.py}
BUNNY=${BUNNY:-../shared/models/bunny.obj}
REPEAT=${REPEAT:-5}
DIMS="176 220 218"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo bench --quiet --bench polygonize --no-run 2>/dev/null
bench() { cargo bench --quiet --bench polygonize 2>/dev/null; }

POLYGONIZE_WRITE_SHAPES="$work/shapes.npy" bench
volumes=("shapes:$work/shapes.npy")

if [[ -f "$PEERS" && -f "$BUNNY" ]]; then
    # The grid the peer's stage timings use: 3 voxels of margin, the bunny centred.
    "$PYTHON" - "$BUNNY" "$work/bunny.json" $DIMS <<'EOF'
import json, sys
import numpy as np, trimesh
m = trimesh.load(sys.argv[1], force='mesh', process=False)
dims = np.array([int(d) for d in sys.argv[3:6]])
lo, hi = m.vertices.min(0), m.vertices.max(0)
h = float(((hi - lo) / (dims - 7)).max())
origin = (lo + hi) / 2 - h * (dims - 1) / 2
json.dump({'dims': dims.tolist(), 'origin': origin.tolist(), 'voxel_size': h}, open(sys.argv[2], 'w'))
EOF
    "$PYTHON" "$PEERS" sdf "$BUNNY" "$work/bunny.json" "$work/bunny.npy"
    volumes+=("bunny signed distance:$work/bunny.npy")
else
    echo "(no $PEERS or $BUNNY: timing the shapes volume only)" >&2
fi

skimage() {
    "$PYTHON" - "$1" "$REPEAT" <<'EOF'
import sys, time
import numpy as np
from skimage import measure
v = np.load(sys.argv[1]).astype(np.float32)
best = float('inf')
verts, faces, _, _ = measure.marching_cubes(v, 0.0)
for _ in range(int(sys.argv[2])):
    t = time.perf_counter()
    verts, faces, _, _ = measure.marching_cubes(v, 0.0)
    best = min(best, time.perf_counter() - t)
print(best, len(faces), len(verts))
EOF
}

echo "| volume | grid | scikit-image s | implicitize s | speed-up | triangles scikit-image | triangles implicitize |"
echo "|---|---|---|---|---|---|---|"
for entry in "${volumes[@]}"; do
    name=${entry%%:*}
    path=${entry#*:}
    read -r peer_s peer_tri _ < <(skimage "$path")
    read -r our_s our_tri _ < <(POLYGONIZE_TIME="$path" POLYGONIZE_REPEAT="$REPEAT" bench)
    ratio=$(awk -v a="$peer_s" -v b="$our_s" 'BEGIN { printf "%.2f", a / b }')
    printf "| %s | %s | %.4f | %.4f | %sx | %s | %s |\n" \
        "$name" "${DIMS// /x}" "$peer_s" "$our_s" "$ratio" "$peer_tri" "$our_tri"
done
echo
echo "speed-up = scikit-image time / implicitize time (above 1 means implicitize is faster);"
echo "$(nproc) cores, RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-all}; best of $REPEAT runs each."
