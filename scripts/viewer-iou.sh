#!/usr/bin/env bash
# The silhouette of `implicitize view`'s page against `implicitize render` (docs/results.md):
# a model fitted from MESH (default the triceratops, at --resolution 150), its page photographed
# by the test browser (headless Chromium, python/tests/browser.py) at six views,
# `#view=AZ,EL&panel=0` in an 800 x 800 window, against `render --size 800 800 --view AZ EL`;
# prints the intersection over union of the two silhouettes and the seconds each page took.
#
# Usage: scripts/viewer-iou.sh [MESH [RESOLUTION]]   (MODEL=file.json uses that model instead;
#   IMPLICITIZE_PAGE_TIMEOUT=SECONDS waits longer than 120 s for a page to draw, as SwiftShader
#   on two cores needs for the bunny's 512 model)
# Needs what scripts/test.sh sets up: target/release/implicitize (or IMPLICITIZE_BIN), the
# environment target/venv (or PYTHON) and Debian's chromium and chromedriver.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
bin=${IMPLICITIZE_BIN:-$root/target/release/implicitize}
python=${PYTHON:-$root/target/venv/bin/python}
mesh=${1:-$root/data/triceratops.obj}
resolution=${2:-150}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

model=${MODEL:-}
if [ -z "$model" ]; then
    model=$work/model.json
    "$bin" fit "$mesh" -o "$model" --resolution "$resolution" --quiet
fi
"$python" - "$bin" "$model" "$work" <<'PY'
import subprocess, sys, time
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, "python/tests")
from browser import chromium, open_page, screenshot

bin, model, work = sys.argv[1], sys.argv[2], Path(sys.argv[3])
start = time.perf_counter()
subprocess.run([bin, "view", model, "-o", work / "model.html", "--quiet"], check=True)
print(f"view: {time.perf_counter() - start:.1f} s")
with chromium(800, 800) as driver:
    for az, el in [(30, 20), (90, 0), (150, -15), (210, 30), (270, 10), (330, -30)]:
        start = time.perf_counter()
        open_page(driver, work / "model.html", f"view={az},{el}&panel=0")
        page = screenshot(driver).sum(axis=2) > 24
        seconds = time.perf_counter() - start
        out = work / "render.png"
        subprocess.run([bin, "render", model, "-o", out, "--size", "800", "800", "--view", str(az), str(el), "--quiet"], check=True)
        picture = np.asarray(Image.open(out).convert("RGBA"))[..., 3] > 0
        iou = (page & picture).sum() / max((page | picture).sum(), 1)
        print(f"view {az},{el}: IoU {iou:.4f} ({picture.sum()} pixels in render's, page {seconds:.1f} s)", flush=True)
PY
