"""The page of `implicitize view` in a real browser (headless Chromium, WebGL2 by SwiftShader):
it draws what `implicitize render` draws, thin parts included, orbits and resets, draws the mesh beside the model and
CSG composites, and its shader's values (and those of `implicitize export --format glsl`) are
the model's `eval` in single precision.

The models: the bunny (../shared/models, else the repository's triceratops) fitted once at a
low resolution, a ball solved from constraints with the r^3 kernel, their blended union, and the
triceratops fitted at 150, whose brow horns are a few voxels thick, and the bunny's model with a
detail level of small bumps (a version 2 model file)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from browser import chromium, drawn, open_page, screenshot, set_inner_size
from conftest import ROOT, TRICERATOPS

BUNNY = ROOT.parent / "shared" / "models" / "bunny.obj"
MESH = BUNNY if BUNNY.is_file() else TRICERATOPS

# render's default view, and one from behind and below.
VIEWS = [(35.0, 20.0), (150.0, -15.0)]

# Six views around the model, from above and below.
SIX_VIEWS = [(30.0, 20.0), (90.0, 0.0), (150.0, -15.0), (210.0, 30.0), (270.0, 10.0), (330.0, -30.0)]

# The page's background with panel=0 is black; the darkest lit surface is about 48 of 255.
BACKGROUND_MAX = 24


def ball_constraints(center: np.ndarray, radius: float, n: int = 60) -> str:
    """CSV constraints of a ball: its surface, its centre inside, a shell outside."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    a = np.pi * (3 - 5**0.5) * i
    d = np.stack([np.sqrt(1 - z * z) * np.cos(a), np.sqrt(1 - z * z) * np.sin(a), z], axis=1)
    rows = [(*(center + radius * v), 0.0) for v in d]
    rows.append((*center, radius))
    rows += [(*(center + 1.5 * radius * v), -0.5 * radius) for v in d[::4]]
    return "x,y,z,value\n" + "\n".join(",".join(repr(float(x)) for x in r) for r in rows) + "\n"


@pytest.fixture(scope="module")
def models(run, tmp_path_factory) -> Path:
    """The models, pages and exported shader, written once."""
    d = tmp_path_factory.mktemp("viewer")
    run("fit", MESH, "-o", d / "mesh.json", "--resolution", "64", "--report", d / "report.json")
    bounds = json.loads((d / "mesh.json").read_text())["bounds"]
    lo, hi = np.array(bounds["min"]), np.array(bounds["max"])
    corner = hi - 0.15 * (hi - lo)
    (d / "ball.csv").write_text(ball_constraints(corner, 0.2 * float((hi - lo).max())))
    run("solve", d / "ball.csv", "-o", d / "ball.json", "--kernel", "r3")
    blend = 0.03 * float((hi - lo).max())
    run("csg", "union", d / "mesh.json", d / "ball.json", "-o", d / "csg.json", "--blend", blend)
    run("view", d / "mesh.json", "-o", d / "model.html")
    run("view", d / "mesh.json", "-o", d / "side.html", "--mesh", MESH, "--report", d / "report.json")
    run("view", d / "csg.json", "-o", d / "csg.html")
    run("export", d / "mesh.json", "--format", "glsl", "-o", d / "mesh.glsl")
    return d


@pytest.fixture(scope="module")
def thin(run, tmp_path_factory) -> Path:
    """The triceratops fitted at --resolution 150 and its page."""
    d = tmp_path_factory.mktemp("thin")
    run("fit", TRICERATOPS, "-o", d / "thin.json", "--resolution", "150")
    run("view", d / "thin.json", "-o", d / "thin.html")
    return d


@pytest.fixture(scope="module")
def browser():
    with chromium(800, 800) as driver:
        yield driver


def rendered(run, model: Path, view, out: Path, size=(800, 800), compare=None) -> np.ndarray:
    """`implicitize render` of the model as RGBA."""
    extra = ["--compare", compare] if compare else []
    run("render", model, "-o", out, "--size", *size, "--view", *view, *extra)
    return np.asarray(Image.open(out).convert("RGBA"))


def silhouette(page: np.ndarray) -> np.ndarray:
    return page.sum(axis=2) > BACKGROUND_MAX


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def timed(what: str, start: float) -> None:
    print(f"{what}: {time.perf_counter() - start:.1f} s")


@pytest.mark.parametrize("view", VIEWS)
def test_the_page_draws_what_render_draws(run, models, browser, view):
    start = time.perf_counter()
    open_page(browser, models / "model.html", f"view={view[0]},{view[1]}&panel=0")
    page = silhouette(screenshot(browser))
    timed(f"page at {view}", start)
    picture = rendered(run, models / "mesh.json", view, models / "render.png")[..., 3] > 0
    assert page.shape == picture.shape
    score = iou(page, picture)
    print(f"silhouette IoU page vs render at {view}: {score:.4f} ({picture.sum()} pixels)")
    assert picture.sum() > 0.05 * picture.size, "the model fills a fair part of the frame"
    assert score >= 0.99, f"IoU {score:.4f} at view {view}"


@pytest.mark.parametrize("view", SIX_VIEWS)
def test_thin_parts_are_drawn_as_render_draws_them(run, thin, browser, view):
    # Sampling the function on a coarse lattice lost the brow horns (IoU 0.970 at 30, 20); the
    # page now marches render's lattice and skips only blocks bounded outside.
    start = time.perf_counter()
    open_page(browser, thin / "thin.html", f"view={view[0]},{view[1]}&panel=0")
    page = silhouette(screenshot(browser))
    timed(f"thin page at {view}", start)
    picture = rendered(run, thin / "thin.json", view, thin / "render.png")[..., 3] > 0
    score = iou(page, picture)
    print(f"triceratops at 150: silhouette IoU page vs render at {view}: {score:.4f}")
    assert picture.sum() > 0.05 * picture.size
    assert score >= 0.99, f"IoU {score:.4f} at view {view}"


def test_the_mesh_is_drawn_beside_the_model_as_render_compare_draws_them(run, models, browser):
    set_inner_size(browser, 1600, 800)
    try:
        open_page(browser, models / "side.html", "view=35,20&panel=0&mode=side")
        page = silhouette(screenshot(browser))
    finally:
        set_inner_size(browser, 800, 800)
    picture = rendered(run, models / "mesh.json", (35, 20), models / "compare.png", compare=MESH)
    picture = picture[..., 3] > 0
    assert page.shape == picture.shape == (800, 1600)
    for half, name in ((slice(0, 800), "mesh"), (slice(800, 1600), "model")):
        score = iou(page[:, half], picture[:, half])
        print(f"silhouette IoU of the {name} half vs render --compare: {score:.4f}")
        assert score >= 0.99, f"{name}: IoU {score:.4f}"


def test_a_drag_turns_the_view_and_reset_brings_it_back(models, browser):
    start = time.perf_counter()
    open_page(browser, models / "side.html")
    panel = browser.find_element(By.ID, "panel").text
    assert "E" in panel and "constraints" in panel and "iterations" in panel and "time" in panel
    assert "not in the model file" not in panel, "the --report's time is shown"
    before = screenshot(browser)
    canvas = browser.find_element(By.ID, "view")
    # From the middle of the picture (beside the panel), 100 pixels right and 24 down.
    actions = ActionChains(browser).move_to_element_with_offset(canvas, 0, 50).click_and_hold()
    for _ in range(4):
        actions.move_by_offset(25, 6)
    actions.release().perform()
    drawn(browser)
    after = screenshot(browser)
    changed = float((np.abs(after.astype(int) - before.astype(int)).sum(axis=2) > 8).mean())
    assert changed > 0.02, f"the drag changed {changed:.4f} of the picture"
    browser.find_element(By.ID, "reset").click()
    drawn(browser)
    again = screenshot(browser)
    differ = float((np.abs(again.astype(int) - before.astype(int)).sum(axis=2) > 8).mean())
    print(f"drag changed {changed:.3f} of the pixels; after reset {differ:.5f} differ")
    assert differ <= 0.001, f"reset left {differ:.4f} of the picture changed"
    timed("drag and reset", start)


def grid(model: Path, n: int) -> np.ndarray:
    """n^3 points over the model's bounds grown by a tenth, exactly representable in f32."""
    bounds = json.loads(model.read_text())["bounds"]
    lo, hi = np.array(bounds["min"]), np.array(bounds["max"])
    pad = 0.1 * (hi - lo)
    axes = [np.linspace(lo[a] - pad[a], hi[a] + pad[a], n) for a in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return points.astype(np.float32).astype(np.float64)


def evaluated(run, model: Path, points: np.ndarray, d: Path) -> np.ndarray:
    np.save(d / "points.npy", points)
    run("eval", model, "--points", d / "points.npy", "-o", d / "values.npy")
    return np.load(d / "values.npy")


def on_gpu(browser, points: np.ndarray, source: str | None = None) -> np.ndarray:
    """(N, 4) gradient and value by the page's shader, or by `source`."""
    return np.array(
        browser.execute_script(
            "return window.implicitize.evaluate(arguments[0], arguments[1])", points.tolist(), source
        ),
        dtype=np.float64,
    )


def relative_value_error(gpu: np.ndarray, values: np.ndarray) -> float:
    return float(np.abs(gpu[:, 3] - values).max() / (values.max() - values.min()))


@pytest.mark.parametrize("model", ["mesh", "csg"])
def test_the_shader_values_equal_eval_to_1e4_of_the_range(run, models, browser, model):
    page = models / ("model.html" if model == "mesh" else "csg.html")
    path = models / f"{model}.json"
    points = grid(path, 16)
    values = evaluated(run, path, points, models)
    open_page(browser, page)
    error = relative_value_error(on_gpu(browser, points), values)
    print(f"{model}: the page's shader vs eval, largest error {error:.2e} of the value range")
    assert error <= 1e-4
    if model == "mesh":
        exported = (models / "mesh.glsl").read_text()
        error = relative_value_error(on_gpu(browser, points, exported), values)
        print(f"{model}: exported GLSL on the GPU vs eval, largest error {error:.2e} of the range")
        assert error <= 1e-4


def test_the_shader_gradient_is_the_functions(run, models, browser):
    path = models / "csg.json"
    points = grid(path, 8)
    size = np.ptp(points, axis=0).max()
    h = 1e-4 * size
    offsets = np.concatenate([np.eye(3) * h, -np.eye(3) * h])
    around = (points[:, None, :] + offsets[None]).reshape(-1, 3)
    values = evaluated(run, path, around, models).reshape(len(points), 6)
    central = (values[:, :3] - values[:, 3:]) / (2 * h)
    open_page(browser, models / "csg.html")
    gradient = on_gpu(browser, points)[:, :3]
    error = np.abs(gradient - central).max() / np.abs(central).max()
    print(f"csg: the shader's gradient vs central differences of eval, {error:.2e} of the largest")
    assert error <= 2e-3


def test_a_csg_composite_is_drawn_as_render_draws_it(run, models, browser):
    view = VIEWS[0]
    open_page(browser, models / "csg.html", f"view={view[0]},{view[1]}&panel=0")
    page = silhouette(screenshot(browser))
    picture = rendered(run, models / "csg.json", view, models / "csg.png")[..., 3] > 0
    alone = rendered(run, models / "mesh.json", view, models / "alone.png")[..., 3] > 0
    assert iou(picture, alone) < 0.95, "the composite differs from the mesh's model alone"
    score = iou(page, picture)
    print(f"csg: silhouette IoU page vs render: {score:.4f}")
    assert score >= 0.99


def spread(points: np.ndarray, count: int) -> np.ndarray:
    """`count` of the points, each the farthest from those chosen before it (the first point
    first): spread over the whole surface whatever order the model stores its centres in."""
    chosen = [0]
    distance = np.linalg.norm(points - points[0], axis=1)
    while len(chosen) < count:
        chosen.append(int(distance.argmax()))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return points[chosen]


@pytest.fixture(scope="module")
def bumpy(run, models) -> Path:
    """The mesh's model with one detail level: at a dozen of its surface centres, Wendland
    functions of support 6% of the model's size, each raising the surface by about half its
    support; and its page and exported GLSL."""
    model = json.loads((models / "mesh.json").read_text())
    base = {k: v for k, v in model["shape"].items() if k != "type"}
    surface = np.array([c for c, k in zip(base["centres"], base["kinds"]) if k == "boundary"])
    centres = spread(surface, 12)
    lo, hi = np.array(model["bounds"]["min"]), np.array(model["bounds"]["max"])
    radius = 0.06 * float((hi - lo).max())
    h = 1e-3 * radius
    offsets = np.concatenate([np.eye(3), -np.eye(3)]) * h
    around = (centres[:, None, :] + offsets[None]).reshape(-1, 3)
    values = evaluated(run, models / "mesh.json", around, models).reshape(len(centres), 6)
    slope = np.linalg.norm((values[:, :3] - values[:, 3:]) / (2 * h), axis=1)
    level = {"radius": radius, "centres": centres.tolist(), "weights": (0.5 * radius * slope).tolist()}
    model.update(version=2, shape={"type": "levels", "base": base, "levels": [level]})
    model.pop("report", None)
    path = models / "bumpy.json"
    path.write_text(json.dumps(model))
    run("view", path, "-o", models / "bumpy.html")
    run("export", path, "--format", "glsl", "-o", models / "bumpy.glsl")
    return path


@pytest.mark.parametrize("view", SIX_VIEWS[::2])
def test_a_model_with_detail_levels_is_drawn_as_render_draws_it(run, models, bumpy, browser, view):
    open_page(browser, bumpy.with_suffix(".html"), f"view={view[0]},{view[1]}&panel=0")
    page = silhouette(screenshot(browser))
    picture = rendered(run, bumpy, view, models / "bumpy.png")[..., 3] > 0
    alone = rendered(run, models / "mesh.json", view, models / "alone.png")[..., 3] > 0
    assert iou(picture, alone) < 0.998, "the bumps change the silhouette"
    score = iou(page, picture)
    print(f"levels: silhouette IoU page vs render at {view}: {score:.4f} (level 0 alone {iou(picture, alone):.4f})")
    assert score >= 0.99, f"IoU {score:.4f} at view {view}"


def test_the_shader_values_of_a_model_with_levels_equal_eval_to_1e5_of_the_range(run, models, bumpy, browser):
    points = grid(bumpy, 16)
    # And the points around the bumps, where the level acts.
    level = json.loads(bumpy.read_text())["shape"]["levels"][0]
    centres, radius = np.array(level["centres"]), level["radius"]
    rng = np.random.default_rng(3)
    near = centres[rng.integers(len(centres), size=1024)] + rng.uniform(-radius, radius, (1024, 3))
    points = np.concatenate([points[: 4096 - 1024], near.astype(np.float32).astype(np.float64)])
    values = evaluated(run, bumpy, points, models)
    open_page(browser, bumpy.with_suffix(".html"))
    for name, source in (("page", None), ("exported GLSL", bumpy.with_suffix(".glsl").read_text())):
        error = relative_value_error(on_gpu(browser, points, source), values)
        print(f"levels: the {name}'s values vs eval at {len(points)} points, {error:.2e} of the range")
        assert error <= 1e-5
