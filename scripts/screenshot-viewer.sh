#!/usr/bin/env bash
# The README's picture of the viewer (docs/images/viewer.png): the bunny (../shared/models)
# fitted, its page written by `implicitize view --mesh`, and that page, mesh beside model with
# its panel, photographed by the test browser (headless Chromium, python/tests/browser.py).
#
# Needs what scripts/test.sh sets up: target/release/implicitize, the environment target/venv
# and Debian's chromium and chromedriver.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
bin=$root/target/release/implicitize
bunny=${BUNNY:-$root/../shared/models/bunny.obj}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$bin" fit "$bunny" -o "$work/bunny.json" --report "$work/report.json" --resolution 128 --quiet
"$bin" view "$work/bunny.json" -o "$work/bunny.html" --mesh "$bunny" --report "$work/report.json" --quiet

"$root/target/venv/bin/python" - "$work/bunny.html" "$root/docs/images/viewer.png" <<'PY'
import sys
from pathlib import Path

sys.path.insert(0, "python/tests")
from browser import chromium, open_page

page, out = Path(sys.argv[1]), Path(sys.argv[2])
with chromium(1500, 640) as driver:
    open_page(driver, page, "view=35,20&mode=side")
    driver.save_screenshot(str(out))
print(f"wrote {out}")
PY
