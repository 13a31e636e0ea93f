"""`implicitize.distance` against brute force, `implicitize.sample` and the `.npz` that
`implicitize sample` writes read back with numpy, and a batch's samples."""

from __future__ import annotations

import json

import numpy as np
import pytest

import implicitize
from implicitize import _implicitize

# A closed, outward cube [0, 2]^3 of 12 triangles.
CORNERS = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], dtype=float)
QUADS = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
FACES = np.array([t for a, b, c, d in QUADS for t in ([a, b, c], [a, c, d])])


def point_triangle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """The distance from p to triangle abc: inside its prism the plane's, else an edge's."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    q = p - np.dot(p - a, n) * n
    inside = all(
        np.dot(np.cross(v - u, q - u), n) >= 0 for u, v in ((a, b), (b, c), (c, a))
    )
    if inside:
        return float(np.linalg.norm(p - q))

    def segment(u: np.ndarray, v: np.ndarray) -> float:
        t = np.clip(np.dot(p - u, v - u) / np.dot(v - u, v - u), 0.0, 1.0)
        return float(np.linalg.norm(p - (u + t * (v - u))))

    return min(segment(a, b), segment(b, c), segment(c, a))


def test_distances_equal_brute_force_signed_inside_positive():
    rng = np.random.default_rng(4)
    points = rng.uniform(-1.0, 3.0, size=(300, 3))
    brute = np.array(
        [min(point_triangle(p, *CORNERS[f]) for f in FACES) for p in points]
    )
    inside = np.all((points > 0) & (points < 2), axis=1)
    values = implicitize.distance((CORNERS, FACES), points)
    assert values.dtype == np.float64 and values.shape == (300,)
    np.testing.assert_allclose(np.abs(values), brute, rtol=1e-12, atol=1e-15)
    assert np.array_equal(values > 0, inside)
    unsigned = implicitize.distance((CORNERS, FACES), points, signed=False)
    np.testing.assert_array_equal(unsigned, np.abs(values))
    values_again, closest = implicitize.distance((CORNERS, FACES), points, closest=True)
    np.testing.assert_array_equal(values_again, values)
    assert closest.shape == (300, 3)
    np.testing.assert_allclose(np.linalg.norm(points - closest, axis=1), brute, rtol=1e-12)


def test_bad_points_and_a_small_memory_limit_are_refused():
    with pytest.raises(ValueError, match="points"):
        implicitize.distance((CORNERS, FACES), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="not finite"):
        implicitize.distance((CORNERS, FACES), [[0.0, np.nan, 0.0]])
    with pytest.raises(MemoryError, match="memory_limit"):
        implicitize.distance((CORNERS, FACES), np.zeros((1000, 3)), memory_limit="1M")
    with pytest.raises(MemoryError, match="memory_limit"):
        implicitize.sample((CORNERS, FACES), 1000, memory_limit="1M")


def test_samples_have_the_asked_counts_and_deepsdfs_signs():
    got = implicitize.sample((CORNERS, FACES), 1001, near_surface=[0.01, 0.002], uniform=0.3)
    points, sdf, pos, neg = got["points"], got["sdf"], got["pos"], got["neg"]
    assert points.shape == (1001, 3) and points.dtype == np.float64
    assert sdf.shape == (1001,) and sdf.dtype == np.float64
    assert pos.dtype == np.float32 and neg.dtype == np.float32
    assert pos.shape == ((sdf < 0).sum(), 4) and neg.shape == ((sdf >= 0).sum(), 4)
    assert np.all(pos[:, 3] > 0) and np.all(neg[:, 3] <= 0)
    np.testing.assert_array_equal(pos[:, :3], points[sdf < 0].astype(np.float32))
    np.testing.assert_array_equal(pos[:, 3], (-sdf[sdf < 0]).astype(np.float32))
    # The last 300 are uniform in the cube's box grown by 10% on every side.
    uniform = points[-300:]
    assert np.all((uniform >= -0.2) & (uniform <= 2.2))
    # The signed distances are the distance query's.
    np.testing.assert_array_equal(implicitize.distance((CORNERS, FACES), points), sdf)
    same = implicitize.sample((CORNERS, FACES), 1001, [0.01, 0.002], 0.3, seed=None)
    np.testing.assert_array_equal(same["points"], points)
    other = implicitize.sample((CORNERS, FACES), 1001, [0.01, 0.002], 0.3, seed=5)
    assert not np.array_equal(other["points"], points)


def test_bad_sample_options_are_refused():
    for kwargs, said in [
        ({"uniform": 1.5}, "uniform"),
        ({"near_surface": [0.01, -0.1]}, "near_surface"),
        ({"near_surface": []}, "near_surface"),
    ]:
        with pytest.raises(ValueError, match=said):
            implicitize.sample((CORNERS, FACES), 100, **kwargs)
    for n in (0, -3):
        with pytest.raises(ValueError, match="number of points"):
            implicitize.sample((CORNERS, FACES), n)


def test_the_defaults_are_the_librarys_and_fill_the_docstring():
    assert implicitize.DEFAULTS["near_surface"] == [0.005, 0.0005]
    assert implicitize.DEFAULTS["uniform"] == 0.2
    doc = " ".join(implicitize.sample.__doc__.split())
    assert "default [0.005, 0.0005]" in doc and "default 0.2" in doc


def test_the_cli_npz_reads_with_numpy_as_sample_returns_it(tmp_path, run):
    mesh = tmp_path / "cube.obj"
    lines = [f"v {x} {y} {z}" for x, y, z in CORNERS]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in FACES]
    mesh.write_text("\n".join(lines) + "\n")
    out = tmp_path / "s.npz"
    run("sample", mesh, "-n", 2000, "-o", out, "--near-surface", "0.01,0.002", "--seed", 3)
    with np.load(out) as npz:
        assert sorted(npz.files) == ["neg", "points", "pos", "sdf"]
        arrays = {name: npz[name] for name in npz.files}
    assert arrays["points"].shape == (2000, 3) and arrays["points"].dtype == np.float64
    assert arrays["sdf"].shape == (2000,) and arrays["sdf"].dtype == np.float64
    assert arrays["pos"].dtype == np.float32 and arrays["pos"].shape[1] == 4
    assert len(arrays["pos"]) + len(arrays["neg"]) == 2000
    assert np.all(arrays["pos"][:, 3] > 0) and np.all(arrays["neg"][:, 3] <= 0)
    inside = np.all((arrays["points"] > 0) & (arrays["points"] < 2), axis=1)
    assert np.array_equal(arrays["sdf"] > 0, inside)
    assert np.array_equal(arrays["neg"][:, :3], arrays["points"][inside].astype(np.float32))
    same = implicitize.sample(str(mesh), 2000, near_surface=[0.01, 0.002], seed=3)
    for name, values in arrays.items():
        np.testing.assert_array_equal(same[name], values)


def test_a_batch_writes_samples_beside_the_model(tmp_path, triceratops):
    out = tmp_path / "out"
    line = _implicitize.batch_convert(
        str(triceratops), "t", str(out), resolution=32, samples=400
    )
    entry = json.loads(line)
    assert entry["status"] == "ok", entry
    assert entry["origin"]["options"]["samples"] == 400
    with np.load(out / "t.samples.npz") as npz:
        assert npz["points"].shape == (400, 3)
    with pytest.raises(ValueError, match="samples"):
        _implicitize.batch_convert(str(triceratops), "t", str(out), samples=0)
