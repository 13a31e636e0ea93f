#!/usr/bin/env bash
# Speed of the RBF solve and evaluation next to scipy's RBFInterpolator (thin-plate spline,
# degree-one polynomial), both measured in this run on this machine.
#
#   PYTHON=/path/to/python-with-scipy scripts/bench-rbf.sh
#
# Runs the criterion benchmarks in benches/rbf.rs, times scipy on the same constraint sets
# (the sphere sets of the solve benchmark and tests/data/bunny_constraints.csv for evaluation at
# 500,000 random points in the bunny's box), and prints a table with the ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}

cargo bench --bench rbf >&2

# OpenBLAS overrides set for old builds slow a current numpy; unset them for the peer only.
env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE "$PYTHON" - > target/rbf-peer.json <<'PY'
import json, time
import numpy as np
from scipy.interpolate import RBFInterpolator

def best(f, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter(); f(); times.append(time.perf_counter() - t)
    return min(times)

def sphere(n):
    i = np.arange(n)
    z = 1 - 2 * (i + 0.5) / n
    r, phi = np.sqrt(1 - z * z), i * 2.399963229728653
    scale = np.where(i % 3 == 2, 1.1, 1.0)
    pts = np.stack([scale * r * np.cos(phi), scale * r * np.sin(phi), scale * z], 1)
    return pts, np.where(i % 3 == 2, -0.1, 0.0)

out = {}
for n in [500, 1500, 2000, 5000]:
    pts, vals = sphere(n)
    out[f"solve/{n}"] = best(lambda: RBFInterpolator(pts, vals, kernel='thin_plate_spline', degree=1),
                             3 if n < 5000 else 1)
c = np.loadtxt('tests/data/bunny_constraints.csv', delimiter=',', skiprows=1)
rbf = RBFInterpolator(c[:, :3], c[:, 3], kernel='thin_plate_spline', degree=1)
lo, hi = c[:, :3].min(0), c[:, :3].max(0)
q = lo + np.random.default_rng(0).random((500_000, 3)) * (hi - lo)
out["eval/eval_700_at_500k"] = best(lambda: rbf(q), 2)
print(json.dumps(out))
PY

"$PYTHON" - <<'PY'
import json
peer = json.load(open('target/rbf-peer.json'))
def ours(name):
    with open(f'target/criterion/{name}/new/estimates.json') as f:
        return json.load(f)['mean']['point_estimate'] / 1e9
print(f"{'benchmark':<24} {'implicitize (s)':>16} {'scipy (s)':>12} {'scipy / ours':>13}")
for name in ['solve/500', 'solve/1500', 'solve/2000', 'solve/5000', 'eval/eval_700_at_500k']:
    o, p = ours(name), peer[name]
    print(f"{name:<24} {o:>16.4f} {p:>12.4f} {p / o:>12.1f}x")
for name in ['grid_200/700', 'grid_200/1500']:
    print(f"{name:<24} {ours(name):>16.4f} {'-':>12} {'-':>13}")
PY
