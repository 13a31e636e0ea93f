#!/usr/bin/env bash
# Faithful fits at 512: `implicitize fit MESH --resolution 512 --target-error 1 --subvoxel
# --mesh-out` on the paper's three models, with the wall time and peak memory of each whole
# process, the fit's own sub-voxel E, the distance between the polygonized implicit and the
# mesh measured independently (50,000 points sampled on each surface, exact point-to-triangle
# distance with libigl; for the bunny only from the mesh to the implicit, its base being open),
# and E against the number of centres over the fit's iterations.
#
# Each fit stops after at most ITERATIONS iterations (default 90; the fits of the three models
# stop earlier, at the target or for want of improvement or of candidates, after 42 to 49).
# The bunny's model is then rendered beside its mesh into docs/images/bunny-512-compare.png.
#
# Usage: [ITERATIONS=N] scripts/fit-512.sh [MODEL...]   (default: bunny horse triceratops)
# Outputs stay in target/fit-512/. Needs Python 3 for libigl and trimesh (made by
# ../shared/bench/setup-peers.sh); the project's own tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
if (($#)); then models=("$@"); else models=(bunny horse triceratops); fi
out=target/fit-512
mkdir -p "$out"
python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --bin implicitize

for model in "${models[@]}"; do
  mesh=$(ls ../shared/models/"$model".* | head -1)
  /usr/bin/time -f "%e %M" -o "$out/$model.time" ./target/release/implicitize fit "$mesh" \
    --resolution 512 --target-error 1 --subvoxel --max-iterations "${ITERATIONS:-90}" --quiet \
    -o "$out/$model.json" --report "$out/$model-report.json" --mesh-out "$out/$model.ply"
  "$python" - "$model" "$mesh" "$out" <<'PY'
import json, sys
import numpy as np
import trimesh

sys.path.insert(0, "scripts")
from surface_distance import distances

model, mesh_path, out = sys.argv[1:]
seconds, kilobytes = open(f"{out}/{model}.time").read().split()
report = json.load(open(f"{out}/{model}-report.json"))
voxel = report["voxel_size"]
goal = trimesh.load(mesh_path, force="mesh")
fitted = trimesh.load(f"{out}/{model}.ply", force="mesh")

kept = report["per_iteration"][report["best_iteration"] - 1]
print(f"## {model} at 512: {sum(report['constraints'].values())} constraints, "
      f"E {kept['max_error_voxels']:.2f} (sub-voxel {kept['max_error_subvoxel_voxels']:.2f}) "
      f"voxels, {report['termination']}")
print(f"   whole process {float(seconds):.1f} s, peak memory {int(kilobytes) / 1e6:.2f} GB")
pairs = [("mesh -> implicit", distances(goal, fitted, voxel))]
if model != "bunny":
    pairs.append(("implicit -> mesh", distances(fitted, goal, voxel)))
for name, d in pairs:
    print(f"   {name}: max {d.max():.2f}, 99.9% {np.percentile(d, 99.9):.2f}, "
          f"mean {d.mean():.3f} voxels")
print("   centres | grid | E (sub-voxel), voxels of the 512 grid")
for line in report["per_iteration"]:
    print(f"   {sum(line['constraints'].values()):>7} | {line['grid']:>7} | "
          f"{line['max_error_voxels']:.2f} ({line['max_error_subvoxel_voxels']:.2f})")
PY
done

if [[ " ${models[*]} " == *" bunny "* ]]; then
  ./target/release/implicitize render "$out/bunny.json" --compare "$(ls ../shared/models/bunny.* | head -1)" \
    --size 560 480 --view 25 15 -o docs/images/bunny-512-compare.png --quiet
fi
