#!/usr/bin/env bash
# Large meshes stay fast: a generated hollow solid of 2.6 million triangles (a bumpy sphere
# with an inward-facing sphere inside, binary PLY) through `sdf` and `fit` at the default
# resolution, with wall time and peak memory (/usr/bin/time). Targets (issue 18): sdf within
# 5 s, fit within 15 s, both under 3 GB. Usage: scripts/bench-hostile.sh [WORKDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-target/bench-hostile}"
mkdir -p "$work"
cargo build --release --locked -p implicitize-cli --bin implicitize --example hostile_mesh
mesh="$work/hollow-2.6m.ply"
[ -f "$mesh" ] || target/release/examples/hostile_mesh hollow "$mesh" 2600000
measure() {
    local name="$1"; shift
    /usr/bin/time -f "$name: %e s, peak %M KB" "$@" --quiet 2>&1 | grep -v '^warning' || true
}
measure "sdf (default resolution)" target/release/implicitize sdf "$mesh" -o "$work/sdf.npy"
measure "fit (default resolution)" target/release/implicitize fit "$mesh" -o "$work/model.json" \
    --report "$work/report.json"
