"""Headless Chromium driving the pages of `implicitize view`: Debian's chromium and chromedriver
(installed by scripts/test.sh where missing) with software WebGL (SwiftShader), through
selenium. Used by test_viewer.py and scripts/screenshot-viewer.sh."""

from __future__ import annotations

import io
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from PIL import Image
from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service

# Where Debian puts them; CHROMIUM and CHROMEDRIVER override.
CHROMIUM = os.environ.get("CHROMIUM", shutil.which("chromium") or "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("CHROMEDRIVER", shutil.which("chromedriver") or "/usr/bin/chromedriver")

# A page draws within this many seconds (the lattice and the first frame on SwiftShader);
# IMPLICITIZE_PAGE_TIMEOUT sets another (scripts/viewer-iou.sh on large models).
TIMEOUT_S = float(os.environ.get("IMPLICITIZE_PAGE_TIMEOUT", "120"))


@contextmanager
def chromium(width: int, height: int):
    """A headless Chromium whose page area is `width` x `height` CSS pixels at a device pixel
    ratio of 1, with WebGL2 by SwiftShader."""
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).is_file():
            raise RuntimeError(f"{path}: not found; scripts/test.sh installs chromium and chromium-driver")
    options = Options()
    options.binary_location = CHROMIUM
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        f"--window-size={width},{height}",
    ):
        options.add_argument(arg)
    driver = webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))
    try:
        driver.set_script_timeout(TIMEOUT_S)
        # The driver's connection must wait as long as the page's script (its default is 120 s;
        # selenium keeps it in its connection's client configuration since 4.26).
        config = getattr(driver.command_executor, "_client_config", None)
        if config is not None:
            config.timeout = TIMEOUT_S + 30
        set_inner_size(driver, width, height)
        yield driver
    finally:
        driver.quit()


def set_inner_size(driver, width: int, height: int) -> None:
    """Sizes the window so that the page itself is `width` x `height`."""
    driver.get("about:blank")
    for _ in range(3):
        inner = driver.execute_script("return [window.innerWidth, window.innerHeight]")
        if inner == [width, height]:
            return
        outer = driver.get_window_size()
        driver.set_window_size(outer["width"] + width - inner[0], outer["height"] + height - inner[1])
    raise RuntimeError(f"cannot size the page to {width} x {height}: it is {inner}")


def open_page(driver, page: Path, address: str = "") -> int:
    """Loads `page` with `address` (the part after #) and waits for a full-resolution frame;
    returns the page's frame count. Fails with the page's own error when it has one."""
    driver.get(page.resolve().as_uri() + ("#" + address if address else ""))
    return drawn(driver)


def drawn(driver) -> int:
    """Waits for the page's next full-resolution frame; its frame count."""
    error = driver.execute_script("return window.implicitize ? window.implicitize.error : 'no viewer'")
    if error:
        raise AssertionError(f"the page failed: {error}")
    return driver.execute_async_script("window.implicitize.drawn().then(arguments[arguments.length - 1])")


def screenshot(driver) -> np.ndarray:
    """The page as an (height, width, 3) uint8 array."""
    png = driver.get_screenshot_as_png()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
