#!/usr/bin/env bash
# Times `implicitize sdf` (the voxel distance), `sdf --exact` and `sdf --exact --band 3` as
# whole processes (wall, user + sys CPU, peak resident memory from /usr/bin/time -v), and
# prints how far the voxel distance lies from the exact one, in voxels (median, 99th
# percentile, max of |voxel sdf - exact sdf / voxel_size|).
#
# Usage: scripts/bench-exact-sdf.sh [MESH] [RESOLUTION] [OUT]
#   defaults: the Stanford bunny at 256, volumes kept in OUT (default a temporary folder):
#   OUT/voxel.npy, OUT/exact.npy and OUT/band3.npy, each with its .json.
# Environment: PYTHON (an interpreter with NumPy; default python3), IMPLICITIZE (the binary;
# default target/release/implicitize, built here).
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-../shared/models/bunny.obj}
resolution=${2:-256}
out=${3:-$(mktemp -d)}
python=${PYTHON:-python3}
if [[ -z ${IMPLICITIZE:-} ]]; then
  cargo build --release --quiet
  bin=${CARGO_TARGET_DIR:-target}/release/implicitize
else
  bin=$IMPLICITIZE
fi
mkdir -p "$out"

# Wall s, CPU s (user + sys), peak MB of `$@`.
measure() {
  /usr/bin/time -v -o "$out/time.txt" "$@" >/dev/null 2>&1
  awk -F': ' '/Elapsed/ {n = split($2, t, ":"); wall = (n == 3) ? t[1] * 3600 + t[2] * 60 + t[3] : t[1] * 60 + t[2]}
    /User time/ {cpu += $2} /System time/ {cpu += $2}
    /Maximum resident/ {mb = $2 / 1024}
    END {printf "%.2f s wall, %.2f s CPU, %.0f MB peak", wall, cpu, mb}' "$out/time.txt"
}

echo "mesh $mesh, resolution $resolution, $(nproc) cores, $(date -u +%F)"
echo "sdf (voxel distance):      $(measure "$bin" sdf "$mesh" --resolution "$resolution" -o "$out/voxel.npy" --quiet)"
echo "sdf --exact:               $(measure "$bin" sdf "$mesh" --resolution "$resolution" --exact -o "$out/exact.npy" --quiet)"
echo "sdf --exact --band 3:      $(measure "$bin" sdf "$mesh" --resolution "$resolution" --exact --band 3 -o "$out/band3.npy" --quiet)"
"$python" - "$out" <<'PY'
import json, sys
import numpy as np
out = sys.argv[1]
voxel = np.load(f"{out}/voxel.npy")
exact = np.load(f"{out}/exact.npy")
band = np.load(f"{out}/band3.npy")
grid = json.load(open(f"{out}/exact.json"))
h = grid["voxel_size"]
limit = np.float32(3 * h)
gap = np.abs(voxel.astype(np.float64) - exact.astype(np.float64) / h)
print(f"grid {grid['dims']}, {voxel.size} voxels; |voxel sdf - exact sdf| in voxels: "
      f"median {np.median(gap):.3f}, p99 {np.percentile(gap, 99):.3f}, max {gap.max():.3f}")
print(f"sign agreement {np.mean(np.signbit(exact) == (voxel < 0)):.6f}; "
      f"band 3 equals the exact volume clamped: {np.array_equal(band, np.clip(exact, -limit, limit))}")
PY
