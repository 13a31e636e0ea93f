#!/usr/bin/env bash
# The speed table of the stages users wait on, with the peer's figure from the same run, at each
# instruction set of the evaluation loops (IMPLICITIZE_ISA), on this machine.
#
#   scripts/bench-speed.sh                  # ISAS="baseline avx2 best"
#   ISAS=best scripts/bench-speed.sh        # the best level this CPU runs only
#   SKIP_20K=1 SKIP_BATCH=1 scripts/bench-speed.sh
#
# Rows, each the wall time of one whole process (`/usr/bin/time`) unless said otherwise:
# - the RBF evaluation of 700 thin-plate centres at 500,000 points (examples/stages: the timed
#   call only) against scipy's RBFInterpolator on the same problem (peers.py stages), and their
#   ratio;
# - `fit --resolution 512 --target-error 1` of the bunny, then `eval` of its model at 1,000,000
#   points uniform in the bunny's box grown by 5% and `mesh --resolution 512` of it;
# - `sample -n 500000` of the bunny;
# - `fit` at the defaults of the bunny, horse and triceratops, and `demo`;
# - `solve` of 20,000 constraints drawn from the bunny (examples/sample_constraints), `eval` of
#   that model at the same 1,000,000 points, `mesh --resolution 512` of it (SKIP_20K=1 leaves
#   these out);
# - scripts/bench-batch.sh's ratio of `batch` to sequential `fit`s (SKIP_BATCH=1 leaves it out;
#   it runs at the best level only).
# Needs the peers' venv (../shared/bench/setup-peers.sh) for scipy and the points. Files go to
# target/bench-speed/; the table is printed and written to target/bench-speed/table.md.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
OUT=$ROOT/target/bench-speed
ISAS=${ISAS:-"baseline avx2 best"}
BUNNY=../shared/models/bunny.obj
mkdir -p "$OUT"

python=$(bash ../shared/bench/setup-peers.sh)
cargo build --release --quiet --bin implicitize --example stages --example sample_constraints
bin=$ROOT/target/release/implicitize

# Wall seconds of a whole process, its output kept in $OUT/last.log.
wall() {
    /usr/bin/time -f "%e" -o "$OUT/time" "$@" > "$OUT/last.log" 2>&1 || {
        echo "bench-speed: failed: $*" >&2
        tail -5 "$OUT/last.log" >&2
        exit 1
    }
    cat "$OUT/time"
}

"$python" - "$BUNNY" "$OUT/points.npy" <<'PY'
import sys
import numpy as np
import trimesh
lo, hi = trimesh.load(sys.argv[1], force="mesh").bounds
centre, half = (lo + hi) / 2, (hi - lo) / 2 * 1.05
points = centre - half + np.random.default_rng(0).random((1_000_000, 3)) * 2 * half
np.save(sys.argv[2], points)
PY

# scipy's time, once: it does not depend on IMPLICITIZE_ISA.
read -r nx ny nz < <("$bin" --quiet sdf "$BUNNY" --resolution 220 -o "$OUT/sdf.npy" &&
    "$python" -c "import json,sys; print(*json.load(open(sys.argv[1]))['dims'])" "$OUT/sdf.json")
peer_eval=$("$python" ../shared/bench/peers.py stages "$BUNNY" "$nx" "$ny" "$nz" |
    "$python" -c "import json,sys; print(json.load(sys.stdin)['rbf_eval_700_at_500k_s'])")

if [[ ${SKIP_20K:-0} != 1 ]]; then
    ./target/release/examples/sample_constraints "$BUNNY" 20000 "$OUT/c20k.csv" > /dev/null
fi

row() { printf '|'; printf ' %s |' "$@"; printf '\n'; }
{
    echo "| measure | ISA | implicitize (s) | peer (s) | target |"
    echo "|---|---|---|---|---|"
} > "$OUT/table.md"

for isa in $ISAS; do
    if [[ $isa == best ]]; then unset IMPLICITIZE_ISA; else export IMPLICITIZE_ISA=$isa; fi
    ours=$(./target/release/examples/stages "$BUNNY" "$nx" "$ny" "$nz" |
        "$python" -c "import json,sys; print(json.load(sys.stdin)['rbf_eval_700_at_500k_s'])")
    ratio=$(echo "$ours / $peer_eval" | bc -l)
    row "RBF evaluation, 700 x 500k (ratio to scipy $(printf %.3f "$ratio"))" "$isa" \
        "$(printf %.3f "$ours")" "$(printf %.3f "$peer_eval")" "ratio <= 0.1" >> "$OUT/table.md"
    t=$(wall "$bin" fit "$BUNNY" --resolution 512 --target-error 1 -o "$OUT/bunny512.imp")
    row "fit --resolution 512 --target-error 1, bunny" "$isa" "$t" "" "<= 60" >> "$OUT/table.md"
    t=$(wall "$bin" eval "$OUT/bunny512.imp" --points "$OUT/points.npy" -o "$OUT/values.npy")
    row "eval of the bunny's 512 model, 1M points" "$isa" "$t" "" "<= 0.5" >> "$OUT/table.md"
    t=$(wall "$bin" mesh "$OUT/bunny512.imp" --resolution 512 -o "$OUT/bunny512.ply")
    row "mesh of that model at 512" "$isa" "$t" "" "<= 10" >> "$OUT/table.md"
    t=$(wall "$bin" sample "$BUNNY" -n 500000 -o "$OUT/samples.npz")
    row "sample 500k points, bunny" "$isa" "$t" "" "<= 1" >> "$OUT/table.md"
    for model in bunny.obj horse.ply triceratops.obj; do
        t=$(wall "$bin" fit "../shared/models/$model" -o "$OUT/default.imp")
        row "fit at the defaults, ${model%.*}" "$isa" "$t" "" "<= 10" >> "$OUT/table.md"
    done
    rm -rf "$OUT/demo"
    t=$(wall "$bin" demo -o "$OUT/demo")
    row "demo" "$isa" "$t" "" "<= 15" >> "$OUT/table.md"
    if [[ ${SKIP_20K:-0} != 1 ]]; then
        t=$(wall "$bin" solve "$OUT/c20k.csv" -o "$OUT/m20k.imp")
        row "solve of 20,000 constraints" "$isa" "$t" "" "<= 15" >> "$OUT/table.md"
        t=$(wall "$bin" eval "$OUT/m20k.imp" --points "$OUT/points.npy" -o "$OUT/v20k.npy")
        row "eval of that model, 1M points" "$isa" "$t" "" "<= 2" >> "$OUT/table.md"
        t=$(wall "$bin" mesh "$OUT/m20k.imp" --resolution 512 -o "$OUT/m20k.ply")
        row "mesh of that model at 512" "$isa" "$t" "" "<= 20" >> "$OUT/table.md"
    fi
done
unset IMPLICITIZE_ISA

if [[ ${SKIP_BATCH:-0} != 1 ]]; then
    ratio=$(scripts/bench-batch.sh | sed -n 's/.*implicitize batch: .*(\(.*\) x sequential)/\1/p')
    row "batch of 12 meshes / 12 sequential fits" "best" "$ratio" "" "<= 0.9" >> "$OUT/table.md"
fi
cat "$OUT/table.md"
