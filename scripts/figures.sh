#!/usr/bin/env bash
# Regenerates the README's pictures into docs/images/ with the release binary:
#   bunny-compare.png      the bunny mesh (left) beside its fitted implicit surface (right),
#                          as the paper's figures 4 and 5
#   triceratops-rreg.png   the triceratops' goal surface coloured by its radius of regularity,
#                          red where small, green where large, as the paper's figure 3
#   triceratops-strip.png  the implicit surface after each iteration of the fit of the
#                          triceratops, left to right, as the paper's figure 1
#
# Usage: scripts/figures.sh [BUNNY]
#   BUNNY defaults to ../shared/models/bunny.obj (the Stanford bunny, open at its base).
# Fits run at modest resolutions so the script takes a minute or so; the fits are seeded, so
# the pictures come out the same each run.
set -euo pipefail
cd "$(dirname "$0")/.."
bunny=${1:-../shared/models/bunny.obj}
if [[ ! -f $bunny ]]; then
    echo "scripts/figures.sh: $bunny: no such file (pass the bunny's path)" >&2
    exit 1
fi
out=docs/images
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release --quiet --bin implicitize
implicitize=./target/release/implicitize
mkdir -p "$out"

echo "bunny: fit at 128, then the mesh beside the implicit surface"
"$implicitize" fit "$bunny" --resolution 128 -o "$work/bunny.json" --quiet
"$implicitize" render "$work/bunny.json" --compare "$bunny" --size 560 480 --view 25 15 \
    -o "$out/bunny-compare.png" --quiet

echo "triceratops: the goal surface at 200 coloured by its radius of regularity"
"$implicitize" render data/triceratops.obj --color rreg --resolution 200 --size 720 480 \
    -o "$out/triceratops-rreg.png" --quiet

echo "triceratops: fit at 96 with a picture of every iteration"
"$implicitize" fit data/triceratops.obj --resolution 96 -o "$work/triceratops.json" \
    --snapshots "$work/snapshots" --quiet
cp "$work/snapshots/strip.png" "$out/triceratops-strip.png"

ls -l "$out"/bunny-compare.png "$out"/triceratops-rreg.png "$out"/triceratops-strip.png
