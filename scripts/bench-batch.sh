#!/usr/bin/env bash
# The batch benchmark: 12 meshes (the paper's bunny, horse and triceratops from ../shared/models
# and the repository's triceratops, three copies each) fitted by 12 `implicitize fit` runs one
# after another, by `implicitize batch` over their folder, and by `python -m implicitize.batch`
# on a Dask LocalCluster (when scripts/test.sh has made target/venv). Prints the wall times and
# the ratios the README quotes (batch / sequential, Dask / batch).
#
# Usage: scripts/bench-batch.sh [RESOLUTION]   (default 96; needs `cargo build --release`)
set -euo pipefail
cd "$(dirname "$0")/.."
resolution=${1:-96}
bin=$PWD/target/release/implicitize
python=$PWD/target/venv/bin/python
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

mkdir "$work/meshes"
for copy in 1 2 3; do
    cp ../shared/models/bunny.obj "$work/meshes/bunny-$copy.obj"
    cp ../shared/models/horse.ply "$work/meshes/horse-$copy.ply"
    cp ../shared/models/triceratops.obj "$work/meshes/triceratops-$copy.obj"
    cp data/triceratops.obj "$work/meshes/small-triceratops-$copy.obj"
done

now() { date +%s.%N; }
seconds() { echo "$2 - $1" | bc; }

start=$(now)
for mesh in "$work"/meshes/*; do
    "$bin" --quiet fit "$mesh" --resolution "$resolution" -o "$work/$(basename "$mesh").json"
done
sequential=$(seconds "$start" "$(now)")

start=$(now)
"$bin" --quiet batch "$work/meshes" -o "$work/batch" --resolution "$resolution"
batch=$(seconds "$start" "$(now)")

echo "12 meshes at --resolution $resolution on $(nproc) cores:"
echo "  12 x implicitize fit, one after another: ${sequential} s"
echo "  implicitize batch:                       ${batch} s ($(echo "scale=2; $batch / $sequential" | bc) x sequential)"

if [ -x "$python" ]; then
    start=$(now)
    "$python" -m implicitize.batch --quiet "$work/meshes" -o "$work/dask" --resolution "$resolution"
    dask=$(seconds "$start" "$(now)")
    echo "  python -m implicitize.batch (LocalCluster, $(nproc) workers): ${dask} s ($(echo "scale=2; $dask / $batch" | bc) x implicitize batch)"
fi
