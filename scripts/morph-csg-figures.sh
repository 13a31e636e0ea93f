#!/usr/bin/env bash
# Makes the README's morph and CSG figures in docs/images/:
#   morph-strip.png        triceratops to bunny, variational (Turk and O'Brien), --align
#   morph-strip-blend.png  the same by the linear blend
#   csg.png                triceratops, a ball, union (blend 0.5), difference (blend 0.2),
#                          intersection (sharp)
#
# Usage: scripts/morph-csg-figures.sh [MODELS_DIR]
#   default: ../shared/models (triceratops.obj and bunny.obj). Takes about a minute.
# The bunny stands in for the horse: alignment moves and scales but does not rotate, and
# horse.ply lies with its up axis along -x while the triceratops and the bunny stand on y.
set -euo pipefail
cd "$(dirname "$0")/.."
models=${1:-../shared/models}
out=docs/images
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"

cargo build --release --quiet --bin implicitize --example render_models
bin=./target/release/implicitize
render=./target/release/examples/render_models

# Fit both models at a modest resolution (the paper's volumes are 320 and 220).
$bin fit "$models/triceratops.obj" --resolution 100 -o "$work/triceratops.json" --quiet
$bin fit "$models/bunny.obj" --resolution 90 -o "$work/bunny.json" --quiet

# Morph: six frames, the bunny moved and scaled onto the triceratops' box.
for method in variational blend; do
    $bin morph "$work/triceratops.json" "$work/bunny.json" --steps 6 --align \
        --method "$method" --resolution 100 --strip-width 200 -o "$work/morph-$method" --quiet
done
cp "$work/morph-variational/strip.png" "$out/morph-strip.png"
cp "$work/morph-blend/strip.png" "$out/morph-strip-blend.png"

# CSG: a ball of radius 1 on the triceratops' flank (its mesh units), solved from constraints:
# 200 boundary points on a Fibonacci sphere, the centre inside and 50 points outside.
awk -v cx=-0.5 -v cy=0.5 -v cz=1.2 -v r=1.0 'BEGIN {
    print "x,y,z,value"
    pi = atan2(0, -1); golden = pi * (3 - sqrt(5))
    for (n = 200; n >= 50; n -= 150) {
        rad = (n == 200) ? r : 1.5 * r; value = (n == 200) ? 0 : -0.5 * r
        for (i = 0; i < n; i++) {
            z = 1 - 2 * (i + 0.5) / n; s = sqrt(1 - z * z); a = golden * i
            printf "%.9f,%.9f,%.9f,%g\n", cx + rad * s * cos(a), cy + rad * s * sin(a), cz + rad * z, value
        }
    }
    printf "%g,%g,%g,%g\n", cx, cy, cz, r
}' > "$work/ball.csv"
$bin solve "$work/ball.csv" -o "$work/ball.json" --quiet
$bin csg union "$work/triceratops.json" "$work/ball.json" --blend 0.5 -o "$work/union.json" --quiet
$bin csg difference "$work/triceratops.json" "$work/ball.json" --blend 0.2 \
    -o "$work/difference.json" --quiet
$bin csg intersection "$work/triceratops.json" "$work/ball.json" \
    -o "$work/intersection.json" --quiet
$render "$out/csg.png" 240 180 30 20 "$work/triceratops.json" "$work/ball.json" \
    "$work/union.json" "$work/difference.json" "$work/intersection.json"
ls -l "$out/morph-strip.png" "$out/morph-strip-blend.png" "$out/csg.png"
