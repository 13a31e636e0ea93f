#!/usr/bin/env bash
# The test command (README "Two commands", called by .ci/run): the Rust tests of every crate of
# the workspace, then the Python package built once and its tests.
#
# 1. `cargo test --release --workspace --locked` (library, command, doctests; it also builds
#    release/implicitize in cargo's target directory, whose outputs the Python tests compare
#    against).
# 2. A virtual environment in target/venv of the repository (ignored by git, kept between runs)
#    with the packages of python/requirements-test.txt from PyPI.
# 3. The package built by maturin in release, into the same target directory as cargo (so the
#    library is compiled once), and installed into the environment.
# 4. pytest over python/tests.
#
# Cargo's target directory is the one cargo itself reports, so CARGO_TARGET_DIR (or a
# build.target-dir in a cargo configuration) is honoured, inside the repository or outside it.
#
# First, what the viewer and shader tests run (Debian packages, installed with apt-get only where
# missing, through sudo when not root): chromium and chromedriver (the page of `implicitize
# view` in a headless browser, python/tests/test_viewer.py) and glslangValidator (the GLSL of
# `implicitize export`, crates/implicitize-cli/tests/cli_view.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

install_missing() {
    local missing=() pair
    for pair in chromium:chromium chromedriver:chromium-driver glslangValidator:glslang-tools; do
        command -v "${pair%%:*}" >/dev/null 2>&1 || missing+=("${pair#*:}")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    local sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null 2>&1 || {
            echo "scripts/test.sh: needs ${missing[*]} (apt-get as root, or sudo)" >&2
            return 1
        }
        sudo=(sudo)
    fi
    echo "scripts/test.sh: installing ${missing[*]}" >&2
    "${sudo[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
}
install_missing

cargo test --release --workspace --locked

target=$(cargo metadata --format-version 1 --no-deps --locked |
    python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')

venv=$root/target/venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet -r python/requirements-test.txt

# maturin from the environment (the build backend), cargo's target directory, no rebuild of
# what `cargo test` compiled unless the extension's flags differ.
PATH="$venv/bin:$PATH" CARGO_TARGET_DIR="$target" \
    "$venv/bin/python" -m pip install --quiet --no-build-isolation --no-deps --force-reinstall ./python

IMPLICITIZE_BIN="$target/release/implicitize" "$venv/bin/python" -m pytest python/tests -q -p no:cacheprovider
