#!/usr/bin/env bash
# Detail levels at a large grid (docs/results.md, "Detail levels at 512"): for each mesh,
# `implicitize fit MESH --resolution R --target-error 1 --mesh-out` as one whole process under
# /usr/bin/time (wall, user + system CPU, peak memory), the model's centres and the size of its
# binary file (the report's model_bytes; the JSON model is what the script reads),
# then the exact distance from 100,000 points sampled by area on the mesh to the polygonized
# model, and back for closed meshes (trimesh samples; `implicitize distance --unsigned`
# measures), as percentiles in voxels of the R grid. For the first mesh it also times `eval` of
# 1,000,000 points uniform in the box and `mesh --resolution R` of the model. Then, for each
# mesh, its error against size level by level, from the report.
#
# Usage: [RESOLUTION=512] scripts/bench-levels.sh [MESH...]
#        (default: the bunny, horse and triceratops of ../shared/models)
# Outputs stay in target/bench-levels/. Needs Python 3 with trimesh (made by
# ../shared/bench/setup-peers.sh); the project's own tests do not.
set -euo pipefail
cd "$(dirname "$0")/.."
if (($#)); then meshes=("$@"); else
    meshes=(../shared/models/bunny.obj ../shared/models/horse.ply ../shared/models/triceratops.obj)
fi
resolution=${RESOLUTION:-512}
out=target/bench-levels
mkdir -p "$out"
rm -f "$out/levels.md"
python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --bin implicitize
bin=$PWD/target/release/implicitize

echo "| mesh | wall | CPU (user + sys) | peak memory | centres | binary model bytes | E | mesh -> model 99.9%, 99.99%, max | model -> mesh 99.9%, 99.99%, max |"
echo "|---|---|---|---|---|---|---|---|---|"
first=1
for mesh in "${meshes[@]}"; do
    name=$(basename "${mesh%.*}")
    /usr/bin/time -f "%e %U %S %M" -o "$out/$name.time" "$bin" fit "$mesh" \
        --resolution "$resolution" --target-error 1 --quiet -o "$out/$name.json" \
        --report "$out/$name-report.json" --mesh-out "$out/$name.ply"
    "$python" - "$bin" "$mesh" "$out" "$name" <<'PY'
import json, subprocess, sys
import numpy as np
import trimesh

bin, mesh_path, out, name = sys.argv[1:]
wall, user, system, kilobytes = open(f"{out}/{name}.time").read().split()
report = json.load(open(f"{out}/{name}-report.json"))
model = json.load(open(f"{out}/{name}.json"))
voxel = report["voxel_size"]
shape = model["shape"]
base, levels = (shape["base"], shape["levels"]) if shape["type"] == "levels" else (shape, [])
centres = len(base["centres"]) + sum(len(level["centres"]) for level in levels)
goal = trimesh.load(mesh_path, force="mesh")
fitted = trimesh.load(f"{out}/{name}.ply", force="mesh")


def distances(source, target_path, tag):
    points, _ = trimesh.sample.sample_surface(source, 100_000, seed=1)
    np.save(f"{out}/{name}-{tag}.npy", np.asarray(points, dtype=np.float64))
    subprocess.run([bin, "distance", target_path, "--points", f"{out}/{name}-{tag}.npy",
                    "-o", f"{out}/{name}-{tag}-d.npy", "--unsigned", "-q"], check=True)
    d = np.load(f"{out}/{name}-{tag}-d.npy") / voxel
    return f"{np.percentile(d, 99.9):.2f}, {np.percentile(d, 99.99):.2f}, {d.max():.2f}"


there = distances(goal, f"{out}/{name}.ply", "there")
back = distances(fitted, mesh_path, "back") if goal.is_watertight else "(open mesh)"
print(f"| {name} | {float(wall):.1f} s | {float(user) + float(system):.1f} s "
      f"| {int(kilobytes) / 1e6:.2f} GB | {centres:,} | {report['model_bytes']:,} "
      f"| {report['max_error_voxels']:.2f} | {there} | {back} |")

# Error against size, level by level, printed after the table.
lv = report.get("levels")
with open(f"{out}/levels.md", "a") as table:
    if lv:
        dims = " x ".join(map(str, lv["base_dims"]))
        table.write(f"\n{name}: errors at the {lv['points']:,} points the levels fit, voxels\n\n"
                    "| model | centres | binary bytes | max error | 99.9% | solve | level's time |\n"
                    "|---|---|---|---|---|---|---|\n"
                    f"| level 0 ({dims}) | {lv['base_centres']:,} | {lv['base_bytes']:,} "
                    f"| {lv['base_max_error_voxels']:.2f} | {lv['base_p999_error_voxels']:.2f} | | |\n")
        for k, level in enumerate(lv["levels"], 1):
            table.write(f"| + level {k} (radius {level['radius_voxels']:g} voxels) "
                        f"| {level['centres']:,} | {level['bytes']:,} "
                        f"| {level['max_error_voxels']:.2f} | {level['p999_error_voxels']:.2f} "
                        f"| {level['solve_iterations']} CG iterations, residual "
                        f"{level['solve_residual']:.1e}, {level['wrong_side_voxels']:,} band voxels "
                        f"| {level['seconds']:.1f} s |\n")
PY
    if ((first)); then
        first=0
        "$python" -c "
import numpy as np, json
m = json.load(open('$out/$name.json'))
lo, hi = np.array(m['bounds']['min']), np.array(m['bounds']['max'])
np.save('$out/eval-points.npy', np.random.default_rng(1).uniform(lo, hi, (1_000_000, 3)))"
        /usr/bin/time -f "eval of 1,000,000 points: %e s wall, %U s user, %S s sys, %M KB" \
            "$bin" eval "$out/$name.json" --points "$out/eval-points.npy" -o "$out/eval.npy" -q
        /usr/bin/time -f "mesh --resolution $resolution: %e s wall, %U s user, %S s sys, %M KB" \
            "$bin" mesh "$out/$name.json" --resolution "$resolution" -o "$out/$name-mesh.ply" -q
    fi
done
cat "$out/levels.md"
