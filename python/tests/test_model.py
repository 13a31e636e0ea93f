"""fit, load, Model and the CSG operations against the command-line tool's own outputs: the
same model file for the same seed, the values of `implicitize eval`, the meshes of
`implicitize mesh`, the pictures of `implicitize render`, the composites of `implicitize csg`."""

import json
import pickle

import numpy as np
import pytest
from conftest import read_png

import implicitize

RESOLUTION = 48


@pytest.fixture(scope="module")
def cli_model(tmp_path_factory, run, triceratops):
    """The CLI's fit of the triceratops: (model file, report file)."""
    folder = tmp_path_factory.mktemp("cli")
    model, report = folder / "model.json", folder / "report.json"
    run("fit", triceratops, "--resolution", RESOLUTION, "--seed", 3, "-o", model, "--report", report)
    return model, report


@pytest.fixture(scope="module")
def model(triceratops):
    return implicitize.fit(triceratops, resolution=RESOLUTION, seed=3)


@pytest.fixture(scope="module")
def points(model):
    lo, hi = (np.array(b) for b in model.bounds)
    rng = np.random.default_rng(7)
    return lo - 0.1 * (hi - lo) + rng.random((2000, 3)) * 1.2 * (hi - lo)


def test_fit_writes_the_cli_model_file(tmp_path, model, cli_model):
    path = tmp_path / "model.json"
    model.save(path)
    assert path.read_bytes() == cli_model[0].read_bytes()


def test_report_is_the_cli_report(model, cli_model):
    cli_report = json.loads(cli_model[1].read_text())
    ours = model.report
    for report in (cli_report, ours):
        report.pop("timings_s")
        for iteration in report["per_iteration"]:
            iteration.pop("timings_s")
    assert ours == cli_report
    assert ours["max_error_voxels"] <= 2.0


def test_values_equal_cli_eval(tmp_path, run, model, cli_model, points):
    np.save(tmp_path / "points.npy", points)
    run("eval", cli_model[0], "--points", tmp_path / "points.npy", "-o", tmp_path / "values.npy")
    expected = np.load(tmp_path / "values.npy")
    values = model(points)
    assert values.dtype == np.float64 and values.shape == (len(points),)
    np.testing.assert_array_equal(values, expected)
    np.testing.assert_array_equal(implicitize.load(cli_model[0])(points.tolist()), expected)
    assert (values > 0).any() and (values < 0).any()


def test_load_reads_the_embedded_report(cli_model):
    loaded = implicitize.load(cli_model[0])
    assert loaded.report == json.loads(cli_model[0].read_text())["report"]
    assert loaded.dim == 3


def test_gradient_matches_finite_differences(model, points):
    h = 1e-5
    gradient = model.gradient(points[:50])
    assert gradient.shape == (50, 3)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        central = (model(points[:50] + step) - model(points[:50] - step)) / (2 * h)
        np.testing.assert_allclose(gradient[:, axis], central, rtol=1e-4, atol=1e-6)


def test_pickle_round_trips_bit_for_bit(tmp_path, model, points, cli_model):
    again = pickle.loads(pickle.dumps(model))
    assert again._state() == model._state()
    assert again.report == model.report
    np.testing.assert_array_equal(again(points), model(points))
    loaded = implicitize.load(cli_model[0])
    assert pickle.loads(pickle.dumps(loaded))._state() == loaded._state()


def test_to_mesh_is_the_cli_mesh(tmp_path, run, cli_model, model):
    out = tmp_path / "surface.obj"
    run("mesh", cli_model[0], "--resolution", 60, "-o", out)
    lines = out.read_text().splitlines()
    cli_vertices = np.array([line.split()[1:] for line in lines if line.startswith("v ")], float)
    cli_faces = np.array([line.split()[1:] for line in lines if line.startswith("f ")], int) - 1
    vertices, faces = model.to_mesh(60)
    assert faces.dtype == np.uint32 and vertices.shape[1] == 3
    np.testing.assert_array_equal(faces, cli_faces)
    np.testing.assert_allclose(vertices, cli_vertices, rtol=1e-6, atol=1e-9)


def test_render_is_the_cli_picture(tmp_path, run, cli_model, model):
    out = tmp_path / "model.png"
    run("render", cli_model[0], "--size", 80, 60, "--view", 120, 10, "-o", out)
    rgba = read_png(out)
    picture = model.render(size=(80, 60), view=(120, 10))
    assert picture.shape == (60, 80, 3) and picture.dtype == np.uint8
    shown = rgba[..., 3] == 255
    assert 0 < shown.sum() < shown.size
    np.testing.assert_array_equal(picture[shown], rgba[..., :3][shown])
    assert (picture[~shown] == 255).all()


@pytest.mark.parametrize("operation", ["union", "intersection", "difference"])
def test_csg_is_the_cli_composite(tmp_path, run, triceratops, cli_model, operation):
    other_path = tmp_path / "other.json"
    run("fit", triceratops, "--resolution", 40, "--seed", 5, "-o", other_path)
    out = tmp_path / "csg.json"
    run("csg", operation, cli_model[0], other_path, "--blend", 0.2, "-o", out)
    a, b = implicitize.load(cli_model[0]), implicitize.load(other_path)
    combined = getattr(implicitize, operation)(a, b, blend=0.2)
    combined.save(tmp_path / "ours.json")
    assert (tmp_path / "ours.json").read_bytes() == out.read_bytes()


def _wendland(t):
    t = np.minimum(t, 1.0)
    return (1.0 - t) ** 4 * (4.0 * t + 1.0)


@pytest.fixture(scope="module")
def levelled(tmp_path_factory, model):
    """The triceratops' model with one detail level written over it (model format 2): the
    model, its level (radius, centres, weights) and the file."""
    folder = tmp_path_factory.mktemp("levels")
    single = folder / "single.json"
    model.save(single)
    data = json.loads(single.read_text())
    lo, hi = (np.array(b) for b in model.bounds)
    radius = 0.2 * float(np.max(hi - lo))
    centres = lo + np.array([[0.3, 0.5, 0.5], [0.6, 0.4, 0.5], [0.5, 0.5, 0.7]]) * (hi - lo)
    weights = np.array([0.02, -0.015, 0.01])
    level = {"radius": radius, "centres": centres.tolist(), "weights": weights.tolist()}
    data["version"] = 2
    data["shape"] = {"type": "levels", "base": data["shape"], "levels": [level]}
    path = folder / "levels.json"
    path.write_text(json.dumps(data))
    return implicitize.load(path), (radius, centres, weights), path


def test_a_levelled_model_adds_its_wendland_functions_to_level_0(model, levelled, points):
    levels, (radius, centres, weights), _ = levelled
    distances = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=2)
    expected = model(points) + (_wendland(distances / radius) * weights).sum(axis=1)
    assert np.allclose(levels(points), expected, rtol=0, atol=1e-12)
    assert "1 detail levels of 3 centres" in repr(levels)


def test_a_levelled_model_s_gradient_is_the_derivative_of_its_value(levelled, points):
    levels = levelled[0]
    p, h = points[:200], 1e-6
    numeric = np.stack(
        [(levels(p + h * e) - levels(p - h * e)) / (2 * h) for e in np.eye(3)], axis=1
    )
    assert np.allclose(levels.gradient(p), numeric, rtol=1e-5, atol=1e-6)


def test_a_levelled_model_pickles_saves_and_matches_cli_eval(tmp_path, run, levelled, points):
    levels, _, path = levelled
    again = pickle.loads(pickle.dumps(levels))
    assert np.array_equal(again(points), levels(points))
    np.save(tmp_path / "points.npy", points)
    run("eval", path, "--points", tmp_path / "points.npy", "-o", tmp_path / "values.npy")
    assert np.array_equal(np.load(tmp_path / "values.npy"), levels(points))
    levels.save(tmp_path / "saved.json")
    assert json.loads((tmp_path / "saved.json").read_text())["version"] == 2


def test_fit_takes_levels_and_refuses_a_negative_count(triceratops):
    assert implicitize.DEFAULTS["levels"] >= 1
    with pytest.raises(ValueError, match="levels must be a whole number of 0 or more, not -1"):
        implicitize.fit(triceratops, resolution=32, levels=-1)
    # Below the grid size where levels apply, `levels` changes nothing.
    a = implicitize.fit(triceratops, resolution=32, seed=1, levels=0)
    b = implicitize.fit(triceratops, resolution=32, seed=1)
    corners = np.array(a.bounds)
    assert np.array_equal(a(corners), b(corners)) and "levels" not in a.report
