#!/usr/bin/env bash
# Thin walls and shells (docs/results.md, "Thin walls and shells"): meshes from the shell_mesh
# example (a hollow bust of 101,000 triangles with walls a voxel thick at the default grid, an
# open hemisphere, a car body), each fitted at the default grid as a solid (the bust is refused
# as too thin) and with `--shell 2`, one whole process each under /usr/bin/time; the report's
# exact distances between the model and the thickened surface, both ways, in voxels.
#
# Usage: scripts/bench-shell.sh   (outputs in target/bench-shell/)
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/bench-shell
mkdir -p "$out"
cargo build --release --quiet --bin implicitize --example shell_mesh
bin=target/release/implicitize
shell_mesh=target/release/examples/shell_mesh
"$shell_mesh" bust "$out/bust.obj" 125000 1 >/dev/null 2>&1
"$shell_mesh" hemisphere "$out/hemisphere.obj" 20000 >/dev/null 2>&1
"$shell_mesh" car "$out/car.obj" 20 >/dev/null 2>&1

echo "| mesh | options | outcome | E | mesh -> model max, 99.9% | model -> mesh max, 99.9% | wall | peak memory |"
echo "|---|---|---|---|---|---|---|---|"
for name in bust hemisphere car; do
    for shell in "" 2; do
        args=()
        [ -n "$shell" ] && args=(--shell "$shell")
        tag=$name${shell:+-shell$shell}
        status=0
        /usr/bin/time -f "%e %M" -o "$out/$tag.time" "$bin" fit "$out/$name.obj" "${args[@]}" \
            -q -o "$out/$tag.json" --report "$out/$tag.report.json" 2>"$out/$tag.err" || status=$?
        read -r seconds kilobytes < <(tail -n1 "$out/$tag.time")
        python3 - "$out/$tag.report.json" "$name" "${shell:+--shell $shell}" "$status" \
            "$out/$tag.err" "$seconds" "$kilobytes" <<'PY'
import json, sys
report, name, options, status, err, seconds, kilobytes = sys.argv[1:]
memory = f"{int(kilobytes) / 1e6:.2f} GB"
if status != "0":
    why = open(err).read().strip().splitlines()[-1]
    print(f"| {name} | {options or '(solid)'} | refused: {why} | | | | {seconds} s | {memory} |")
    sys.exit()
r = json.load(open(report))
d = r["mesh_distance"]
there, back = d["mesh_to_model"], d["model_to_mesh"]
print(f"| {name} | {options or '(solid)'} | fitted | {r['max_error_voxels']:.2f} "
      f"| {there['max']:.2f}, {there['p99.9']:.2f} | {back['max']:.2f}, {back['p99.9']:.2f} "
      f"| {seconds} s | {memory} |")
PY
    done
done
