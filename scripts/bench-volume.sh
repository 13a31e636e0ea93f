#!/usr/bin/env bash
# Times `implicitize sdf` against the Python peer (libigl's fast winding number + SciPy's
# exact EDT, ../shared/bench/peers.py) on the same grid in the same run, as whole
# processes, and prints a table with the ratio and the agreement of inside/outside.
#
# Usage: scripts/bench-volume.sh [MESH] [RESOLUTION] [RUNS]
#   defaults: the Stanford bunny at 220 (the paper's 176 x 220 x 218 volume), 3 runs (best kept).
# Environment: PEERS (peers.py), PYTHON (the peers' interpreter, by default the one named in
# /tmp/peers-python.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-../shared/models/bunny.obj}
resolution=${2:-220}
runs=${3:-3}
peers=${PEERS:-../shared/bench/peers.py}
python=${PYTHON:-$(cat /tmp/peers-python.txt 2>/dev/null || true)}
[[ -x $python ]] || { echo "no peer Python: set PYTHON or run setup-peers.sh" >&2; exit 1; }
cargo build --release --quiet
bin=target/release/implicitize
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Best wall time (s) and its user+sys CPU time of `$@` over $runs runs.
best() {
  local best_wall="" best_cpu=""
  for _ in $(seq "$runs"); do
    /usr/bin/time -f "%e %U %S" -o "$tmp/time" "$@" >/dev/null 2>&1
    read -r wall user sys <"$tmp/time"
    if [[ -z $best_wall ]] || (($(echo "$wall < $best_wall" | bc))); then
      best_wall=$wall best_cpu=$(echo "$user + $sys" | bc)
    fi
  done
  echo "$best_wall $best_cpu"
}

ours=$(best "$bin" sdf "$mesh" --resolution "$resolution" -o "$tmp/ours.npy" --quiet)
peer=$(best "$python" "$peers" sdf "$mesh" "$tmp/ours.json" "$tmp/peer.npy")
dims=$("$python" -c "import json; print(' x '.join(map(str, json.load(open('$tmp/ours.json'))['dims'])))")
agreement=$("$python" - "$tmp/ours.npy" "$tmp/peer.npy" <<'PY'
import sys, numpy as np
ours, peer = np.load(sys.argv[1]), np.load(sys.argv[2])
far = np.abs(peer) > 1
print(f"{100 * ((ours > 0) == (peer > 0))[far].mean():.4f}% of {far.sum()} voxels more than 1 voxel from the surface")
PY
)
read -r ow oc <<<"$ours"
read -r pw pc <<<"$peer"
echo "$(basename "$mesh") at --resolution $resolution ($dims), best of $runs, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
printf '| %-30s | %8s | %8s |\n' "sdf as a process" "wall s" "cpu s"
printf '|%s|%s|%s|\n' "------------------------------" "----------" "----------"
printf '| %-30s | %8.2f | %8.2f |\n' "implicitize sdf" "$ow" "$oc" "peers.py sdf (libigl + scipy)" "$pw" "$pc"
printf '| %-30s | %7.1fx | %7.1fx |\n' "ratio (peer / implicitize)" "$(echo "$pw / $ow" | bc -l)" "$(echo "$pc / $oc" | bc -l)"
echo "inside/outside agreement with libigl (w > 0.5): $agreement"
