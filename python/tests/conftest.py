"""Fixtures of the Python tests: the repository's triceratops, the command-line tool (whose
outputs the package must reproduce) and a reader of its PNG pictures."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TRICERATOPS = ROOT / "data" / "triceratops.obj"


def cargo_target_dir() -> Path:
    """The workspace's target directory as cargo reports it (CARGO_TARGET_DIR honoured)."""
    done = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.fail(f"cargo metadata failed, so no target directory: {done.stderr}")
    return Path(json.loads(done.stdout)["target_directory"])


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `implicitize` binary: IMPLICITIZE_BIN, or the release build in cargo's target
    directory."""
    if "IMPLICITIZE_BIN" in os.environ:
        path = Path(os.environ["IMPLICITIZE_BIN"])
    else:
        path = cargo_target_dir() / "release" / "implicitize"
    if not path.is_file():
        pytest.fail(f"{path}: no implicitize binary; run `cargo build --release` first")
    return path


@pytest.fixture(scope="session")
def run(cli):
    """Runs the tool with arguments; returns the completed process (stderr kept)."""

    def run(*args, check=True):
        done = subprocess.run(
            [str(cli), "--quiet", *map(str, args)], capture_output=True, text=True
        )
        if check and done.returncode != 0:
            raise AssertionError(f"implicitize {args} failed: {done.stderr}")
        return done

    return run


@pytest.fixture(scope="session")
def triceratops() -> Path:
    return TRICERATOPS


def read_png(path: Path) -> np.ndarray:
    """An 8-bit RGBA, non-interlaced PNG (what the tool writes) as (height, width, 4) uint8."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat = 8, b""
    while pos < len(data):
        (length,), kind = struct.unpack(">I", data[pos : pos + 4]), data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, color, interlace) == (8, 6, 0), f"{path}: not 8-bit RGBA"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * 4
    out = np.zeros((height, stride), dtype=np.int32)
    for y in range(height):
        line = raw[y * (stride + 1) : (y + 1) * (stride + 1)]
        kind, row = line[0], np.frombuffer(line[1:], dtype=np.uint8).astype(np.int32)
        up = out[y - 1] if y else np.zeros(stride, dtype=np.int32)
        out[y] = _unfilter(kind, row, up)
    return out.reshape(height, width, 4).astype(np.uint8)


def _unfilter(kind: int, row: np.ndarray, up: np.ndarray) -> np.ndarray:
    """One PNG scanline undone from its filter (types 0 to 4, 4 bytes a pixel)."""
    if kind in (0, 2):
        return (row + (up if kind == 2 else 0)) % 256
    cur = np.zeros_like(row)
    for i in range(len(row)):
        a = cur[i - 4] if i >= 4 else 0
        c = up[i - 4] if i >= 4 else 0
        if kind == 1:
            pred = a
        elif kind == 3:
            pred = (a + up[i]) // 2
        else:
            p = a + up[i] - c
            pa, pb, pc = abs(p - a), abs(p - up[i]), abs(p - c)
            pred = a if pa <= pb and pa <= pc else (up[i] if pb <= pc else c)
        cur[i] = (row[i] + pred) % 256
    return cur
