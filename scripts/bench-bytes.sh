#!/usr/bin/env bash
# Accuracy per byte: Chamfer-L1 and the 99.9th percentile of the distance to the original mesh
# against the bytes stored, for implicitize's models (`fit --max-bytes N` over a ladder of
# budgets, the defaults, and --resolution 512 --target-error 1), Open3D's quadric decimation
# stored plainly and by Draco at 11 and 14 bits, and the whole mesh by Draco at 14 bits, on the
# paper's three models. The measure and every option: scripts/bench_bytes.py (--help).
#
# Usage: [IMPLICITIZE=BINARY] scripts/bench-bytes.sh [--quick] [--models NAME...]
#          [--models-dir DIR] [--out-dir DIR] [--budgets N...] [--no-512] [--run OPTIONS]
#          [--suffix .imp]
#   defaults: ../shared/models, target/bench-bytes/, the release build (never built here).
# The whole run takes 10 to 15 minutes on 2 cores (the peers about 1), --quick a few. Needs
# the Python of ../shared/bench/setup-peers.sh, to which it adds matplotlib; the project's own
# tests do not.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
python=$(bash "$repo/../shared/bench/setup-peers.sh")
"$python" -c 'import open3d' 2>/dev/null ||
  { echo "Open3D does not import (on Debian it needs libusb-1.0-0)" >&2; exit 1; }
"$python" -c 'import matplotlib' 2>/dev/null ||
  "$python" -m pip install -q --disable-pip-version-check matplotlib >&2
exec "$python" "$repo/scripts/bench_bytes.py" "$@"
