"""Errors: ValueError or OSError with the command-line tool's messages, and every input checked
before it reaches the library."""

import numpy as np
import pytest

import implicitize


def cli_message(run, *args):
    done = run(*args, check=False)
    assert done.returncode == 1
    assert done.stderr.startswith("error: ")
    return done.stderr[len("error: ") :].strip()


def test_missing_mesh_is_an_oserror_with_the_cli_message(tmp_path, run):
    missing = tmp_path / "missing.obj"
    with pytest.raises(OSError) as raised:
        implicitize.fit(missing, resolution=40)
    assert str(raised.value) == cli_message(run, "fit", missing, "-o", tmp_path / "m.json")


def test_broken_mesh_is_a_valueerror_with_the_cli_message(tmp_path, run):
    broken = tmp_path / "broken.obj"
    broken.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(ValueError) as raised:
        implicitize.signed_distance(broken, resolution=40)
    assert str(raised.value) == cli_message(run, "sdf", broken, "-o", tmp_path / "s.npy")
    assert "broken.obj" in str(raised.value)


def test_not_a_model_file_has_the_cli_message(tmp_path, run, triceratops):
    points = tmp_path / "p.npy"
    np.save(points, np.zeros((1, 3)))
    with pytest.raises(ValueError) as raised:
        implicitize.load(triceratops)
    message = cli_message(run, "eval", triceratops, "--points", points, "-o", tmp_path / "v.npy")
    assert str(raised.value) == message


@pytest.mark.parametrize(
    "mesh, message",
    [
        ((np.zeros((3, 2)), np.array([[0, 1, 2]])), "vertices: expected an (N, 3) array"),
        ((np.eye(3), np.array([[0, 1, 3]])), "refers to a vertex outside 0..3"),
        ((np.eye(3), np.array([[0, -1, 2]])), "refers to a vertex outside 0..3"),
        ((np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2]]), "not finite"),
        ((np.eye(3), np.zeros((0, 3), int)), "the mesh has no triangles"),
        ((np.eye(3), np.array([[0.0, 1.0, 2.0]])), "faces: expected integer"),
    ],
)
def test_bad_arrays_are_valueerrors(mesh, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        implicitize.voxelize(mesh, resolution=20)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"resolution": 0}, "grid: 0 voxels along an axis is outside the accepted range"),
        ({"target_error": float("nan")}, "target_error must be a finite number"),
        ({"method": "magic"}, 'method takes one of "iterative", "naive", not "magic"'),
        ({"max_iterations": 0}, "max_iterations must be at least 1, not 0"),
        ({"memory_limit": "lots"}, 'memory size "lots": expected a positive number'),
        ({"max_constraints": -5}, "max_constraints must be a whole number of 0 or more, not -5"),
        ({"dims": [10, 10]}, r"dims must be three whole numbers of 0 or more, not \[10, 10\]"),
        ({"seed": True}, "seed must be a whole number of 0 or more, not True"),
        ({"resolution": 20, "dims": [9, 9, 9]}, "give resolution or dims, not both"),
    ],
)
def test_bad_options_are_valueerrors(triceratops, kwargs, message):
    with pytest.raises(ValueError, match=message):
        implicitize.fit(triceratops, **kwargs)


def test_a_keyword_that_is_no_setting_is_a_typeerror(triceratops):
    with pytest.raises(TypeError, match="fit\\(\\) got an unexpected keyword argument 'resolutoin'"):
        implicitize.fit(triceratops, resolutoin=32)


def test_bad_points_and_pictures_are_valueerrors(triceratops):
    model = implicitize.fit(triceratops, resolution=32)
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\) array"):
        model(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="point 1 has a coordinate that is not finite"):
        model.gradient([[0, 0, 0], [0, np.inf, 0]])
    with pytest.raises(ValueError, match="each side must be 1 to"):
        model.render(size=(0, 10))
    with pytest.raises(ValueError, match="the blend radius -1 is not a finite number"):
        implicitize.union(model, model, blend=-1)


def test_not_a_mesh_is_a_typeerror():
    with pytest.raises(TypeError, match="mesh: expected a path"):
        implicitize.fit(42)


def open_hemisphere(rings=12, segments=24):
    """The upper half of a unit sphere, open along its equator."""
    vertices = [(0.0, 0.0, 1.0)]
    for r in range(1, rings + 1):
        polar = 0.5 * np.pi * r / rings
        for s in range(segments):
            azimuth = 2 * np.pi * s / segments
            vertices.append(
                (np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar))
            )
    faces = [(0, 1 + s, 1 + (s + 1) % segments) for s in range(segments)]
    for r in range(1, rings):
        a, b = 1 + (r - 1) * segments, 1 + r * segments
        for s in range(segments):
            t = (s + 1) % segments
            faces += [(a + s, b + s, b + t), (a + s, b + t, a + t)]
    return np.array(vertices), np.array(faces)


def test_a_mesh_open_over_much_of_the_grid_is_refused_unless_solid(tmp_path, run):
    vertices, faces = open_hemisphere()
    path = tmp_path / "bowl.obj"
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError) as raised:
        implicitize.fit(path, resolution=48)
    python = str(raised.value)
    assert "near one half" in python and "(shell=2)" in python and "(solid)" in python
    cli = cli_message(run, "fit", path, "-o", tmp_path / "m.imp", "--resolution", "48")
    assert cli.startswith(f"{path}: the mesh is open") and "(--solid)" in cli
    assert python == cli.replace("--shell 2", "shell=2").replace("--solid", "solid")
    with pytest.warns(UserWarning, match="the mesh is open"):
        model = implicitize.fit(path, resolution=48, solid=True, max_iterations=1)
    target = model.report["target"]
    assert target["reached_voxels"] == pytest.approx(model.report["max_error_voxels"])
    assert target["met"] == (target["reached_voxels"] <= target["target_voxels"])
