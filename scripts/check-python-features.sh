#!/usr/bin/env bash
# Checks that the Python extension's build (maturin, `-p implicitize-python`) enables the same
# features of every shared dependency as `cargo test --workspace` does with the dev-dependencies,
# so that scripts/test.sh compiles the library once. Prints each dependency whose features
# differ (add it to python/Cargo.toml's list) and exits non-zero if there is one.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo tree --locked --prefix none -f "{p} {f}" --workspace -e normal,dev > "$tmp/tests"
cargo tree --locked --prefix none -f "{p} {f}" -p implicitize-python -e normal > "$tmp/extension"
python3 - "$tmp/tests" "$tmp/extension" <<'PY'
import sys

def features(path):
    found = {}
    for line in open(path):
        words = line.replace(" (*)", "").split()
        if len(words) >= 2:
            found.setdefault(" ".join(words[:2]), set()).add(" ".join(words[2:]))
    return found

workspace, extension = features(sys.argv[1]), features(sys.argv[2])
differ = [k for k in sorted(extension) if k in workspace and extension[k] != workspace[k]]
for k in differ:
    print(f"{k}: the extension's build has {sorted(extension[k])}, the tests' {sorted(workspace[k])}")
sys.exit(1 if differ else 0)
PY
