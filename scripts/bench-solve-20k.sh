#!/usr/bin/env bash
# Our RBF solve (iterative above 2,500 constraints) and evaluation next to ferreus_rbf 0.2.2
# (FGMRES preconditioned by domain decomposition, black-box FMM; peers/ferreus), on the same
# constraints, in one run on this machine.
#
#   scripts/bench-solve-20k.sh                         # 20,000 constraints
#   COUNTS="5000 10000 20000" scripts/bench-solve-20k.sh
#
# Environment: COUNTS (constraint counts, default 20000), POINTS (evaluation points, default
# 1000000), MESH (default ../shared/models/bunny.obj), SEED (0), OFFSET (0.005 of the box
# diagonal), PEER_ORDERS (FMM orders for the peer, default "9 12"; 9 is the crate's default
# for r^2 log r), MESH_TIMEOUT (seconds for `implicitize mesh`, default 600), MESH_RESOLUTION
# (512), SKIP_MESH=1 to leave `implicitize mesh` out, IMPLICITIZE=/path/to/implicitize to time
# another build of the binary (for instance one of an earlier commit). CARGO_TARGET_DIR applies
# to the main project only; the peer is always built in target/peers.
#
# For each count: `examples/sample_constraints.rs` draws the constraints from the mesh (a
# third on the surface with value 0, a third OFFSET inside with value +d, a third outside with
# -d) and, once, POINTS random points in the mesh's box grown by 5%. Then, one process at a
# time, each timed by /usr/bin/time (wall seconds and peak resident memory):
#   implicitize solve C.csv -o M.json; implicitize eval M.json --points P.npy -o V.npy;
#   implicitize mesh M.json -o mesh.ply --resolution 512 (under `timeout`);
#   ferreus-peer C.csv --points P.npy --out V-ferreus-oK.npy --order K, for each K.
# It prints a markdown table:
# - solve s / eval s: the tool's own timing of the solve / of the evaluation at the points
#   (ours from its stderr line, the peer's from its JSON); "process s" and "peak MB" are the
#   whole process's (ours: the solve process; the peer's one process also evaluates at the
#   constraints, sums the residual directly in O(N^2) and evaluates at the points).
# - residual: max |f(c_i) - h_i| / (max h - min h) over the constraints. Ours is the model's
#   `shape.residual` (relative to max |h_i|) times max |h_i| / (max h - min h); the peer's as
#   the crate evaluates it (FMM), and, in "direct residual", recomputed from its weights and
#   polynomial by an exact f64 direct sum.
# - vs ours: max |ours - peer| / (max h - min h) at the points, and the fraction of points
#   where the signs (inside / outside) disagree.
# Files go to target/bench-solve-20k/ (constraints, points, models, values, logs, table.md).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

COUNTS=${COUNTS:-20000}
POINTS=${POINTS:-1000000}
MESH=${MESH:-../shared/models/bunny.obj}
SEED=${SEED:-0}
OFFSET=${OFFSET:-0.005}
PEER_ORDERS=${PEER_ORDERS:-"9 12"}
MESH_TIMEOUT=${MESH_TIMEOUT:-600}
MESH_RESOLUTION=${MESH_RESOLUTION:-512}
SKIP_MESH=${SKIP_MESH:-0}
OUT=$ROOT/target/bench-solve-20k
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
PEER_TARGET=$ROOT/target/peers

for tool in jq awk /usr/bin/time timeout; do
    command -v "$tool" > /dev/null || { echo "bench-solve-20k: needs $tool" >&2; exit 1; }
done
[[ -f $MESH ]] || { echo "bench-solve-20k: no mesh at $MESH" >&2; exit 1; }
mkdir -p "$OUT"

echo "building implicitize (release) in $TARGET" >&2
if [[ -n ${IMPLICITIZE:-} ]]; then
    cargo build --release --example sample_constraints >&2
else
    cargo build --release --bin implicitize --example sample_constraints >&2
    IMPLICITIZE=$TARGET/release/implicitize
fi
echo "building peers/ferreus (release) in $PEER_TARGET" >&2
CARGO_TARGET_DIR=$PEER_TARGET cargo build --release --locked \
    --manifest-path peers/ferreus/Cargo.toml >&2
SAMPLE=$TARGET/release/examples/sample_constraints
PEER=$PEER_TARGET/release/ferreus-peer
DIFF=$PEER_TARGET/release/npy-diff

# timed NAME CMD...: runs CMD with stdout to NAME.out and stderr to NAME.err, puts "seconds
# peak_kb" in NAME.time and returns CMD's status.
timed() {
    local name=$1
    shift
    local status=0
    /usr/bin/time -f "%e %M" -o "$OUT/$name.time" "$@" > "$OUT/$name.out" 2> "$OUT/$name.err" \
        || status=$?
    return $status
}
# Wall seconds / peak MB of a timed run.
wall() { awk 'END { print $1 }' "$OUT/$1.time"; }
peak_mb() { awk 'END { printf "%.0f", $2 / 1024 }' "$OUT/$1.time"; }
fmt() { awk -v x="$1" -v f="$2" 'BEGIN { if (x == "" || x == "null") print "n/a"; else printf f, x }'; }

# The points do not depend on the constraint count (the sampler draws them from their own
# stream), so one file serves every count.
P=$OUT/points-$POINTS-seed$SEED.npy
first=${COUNTS%% *}
"$SAMPLE" "$MESH" "$first" "$OUT/c$first.csv" --seed "$SEED" --offset "$OFFSET" \
    --points "$POINTS" "$P" >&2

TABLE=$OUT/table.md
{
    echo "| constraints | tool | solve s | process s | peak MB | residual / range | direct residual / range | eval s at $POINTS pts | eval peak MB | max \|ours - peer\| / range | sign disagree |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
} > "$TABLE"
row() { echo "| $* |" | sed 's/\t/ | /g' >> "$TABLE"; }

for n in $COUNTS; do
    C=$OUT/c$n.csv
    rm -f "$OUT/m$n.json" "$OUT/v$n-"*.npy "$OUT/mesh$n.ply" "$OUT/diff-"*"-$n.json"
    "$SAMPLE" "$MESH" "$n" "$C" --seed "$SEED" --offset "$OFFSET" >&2
    read -r range maxabs < <(awk -F, 'NR > 1 && NF == 4 {
            if (lo == "" || $4 < lo) lo = $4; if (hi == "" || $4 > hi) hi = $4
            a = $4 < 0 ? -$4 : $4; if (a > m) m = a }
        END { print hi - lo, m }' "$C")

    echo "n=$n: implicitize solve" >&2
    ours_solve="failed" ours_residual="" ours_eval="n/a" ours_eval_peak="n/a"
    if timed "ours-solve-$n" "$IMPLICITIZE" solve "$C" -o "$OUT/m$n.json"; then
        ours_solve=$(sed -n 's/.* in \([0-9.]*\) s, relative residual.*/\1/p' "$OUT/ours-solve-$n.err")
        r=$(jq -r '.shape.residual' "$OUT/m$n.json")
        ours_residual=$(awk -v r="$r" -v m="$maxabs" -v g="$range" 'BEGIN { print r * m / g }')
        echo "n=$n: implicitize eval" >&2
        if timed "ours-eval-$n" "$IMPLICITIZE" eval "$OUT/m$n.json" --points "$P" \
            -o "$OUT/v$n-ours.npy"; then
            ours_eval=$(sed -n 's/^evaluated .* in \([0-9.]*\) s;.*/\1/p' "$OUT/ours-eval-$n.err")
            ours_eval_peak=$(peak_mb "ours-eval-$n")
        else
            ours_eval="failed"
        fi
    fi
    row "$n	implicitize solve + eval	$(fmt "$ours_solve" %.2f)	$(wall "ours-solve-$n")	$(peak_mb "ours-solve-$n")	$(fmt "$ours_residual" %.2e)	n/a	$(fmt "$ours_eval" %.2f)	$ours_eval_peak	-	-"

    if [[ $SKIP_MESH != 1 && -f $OUT/m$n.json ]]; then
        echo "n=$n: implicitize mesh --resolution $MESH_RESOLUTION (timeout $MESH_TIMEOUT s)" >&2
        status=0
        timed "ours-mesh-$n" timeout "$MESH_TIMEOUT" "$IMPLICITIZE" mesh "$OUT/m$n.json" \
            -o "$OUT/mesh$n.ply" --resolution "$MESH_RESOLUTION" || status=$?
        if [[ $status == 0 ]]; then
            mesh="$(wall "ours-mesh-$n") s"
        elif [[ $status == 124 ]]; then
            mesh="timeout after $MESH_TIMEOUT s"
        else
            mesh="failed (status $status)"
        fi
        row "$n	implicitize mesh --resolution $MESH_RESOLUTION	$mesh	-	$(peak_mb "ours-mesh-$n")	-	-	-	-	-	-"
    fi

    for k in $PEER_ORDERS; do
        name=peer-o$k-$n
        echo "n=$n: ferreus-peer --order $k" >&2
        V=$OUT/v$n-ferreus-o$k.npy
        if ! timed "$name" "$PEER" "$C" --points "$P" --out "$V" --order "$k"; then
            row "$n	ferreus_rbf order $k	failed (see $name.err)	$(wall "$name")	$(peak_mb "$name")	-	-	-	-	-	-"
            continue
        fi
        j() { jq -r "select(.event == \"$1\" and (.source // \"\") == \"$2\") | .$3" "$OUT/$name.out"; }
        iters=$(j solve "" iterations)
        compare="n/a" sign="n/a"
        if [[ -f $OUT/v$n-ours.npy ]]; then
            "$DIFF" "$OUT/v$n-ours.npy" "$V" --scale "$range" > "$OUT/diff-o$k-$n.json"
            compare=$(fmt "$(jq -r .max_rel "$OUT/diff-o$k-$n.json")" %.2e)
            sign=$(fmt "$(jq -r .sign_disagree_fraction "$OUT/diff-o$k-$n.json")" %.1e)
        fi
        row "$n	ferreus_rbf order $k ($iters FGMRES its)	$(fmt "$(j solve "" seconds)" %.2f)	$(wall "$name")	$(peak_mb "$name")	$(fmt "$(j residual ferreus max_rel_range)" %.2e)	$(fmt "$(j residual direct max_rel_range)" %.2e)	$(fmt "$(j eval "" seconds)" %.2f)	(in process)	$compare	$sign"
    done
done

echo >&2
cat "$TABLE"
