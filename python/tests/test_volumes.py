"""voxelize and signed_distance give the command-line tool's volumes bit for bit, from any
kind of mesh input."""

import json

import numpy as np
import pytest
import trimesh

import implicitize


@pytest.mark.parametrize(
    "function, command", [(implicitize.voxelize, "voxelize"), (implicitize.signed_distance, "sdf")]
)
@pytest.mark.parametrize("grid", [["--resolution", "40"], ["--dims", "30", "44", "36"]])
def test_volume_equals_the_cli(tmp_path, run, triceratops, function, command, grid):
    out = tmp_path / "volume.npy"
    run(command, triceratops, *grid, "-o", out)
    expected = np.load(out)
    meta = json.loads(out.with_suffix(".json").read_text())
    if grid[0] == "--resolution":
        volume = function(triceratops, resolution=int(grid[1]))
    else:
        volume = function(triceratops, dims=[int(d) for d in grid[1:]])
    assert volume.values.dtype == np.float32 and volume.values.flags["C_CONTIGUOUS"]
    assert volume.values.shape == tuple(meta["dims"]) == volume.dims
    np.testing.assert_array_equal(volume.values, expected)
    assert list(volume.origin) == meta["origin"]
    assert volume.voxel_size == meta["voxel_size"]


def test_arrays_and_trimesh_give_the_same_volume(triceratops):
    mesh = trimesh.load(triceratops, process=False)
    from_trimesh = implicitize.signed_distance(mesh, resolution=40)
    from_arrays = implicitize.signed_distance((mesh.vertices, mesh.faces), resolution=40)
    from_lists = implicitize.signed_distance(
        (mesh.vertices.tolist(), mesh.faces.tolist()), resolution=40
    )
    from_path = implicitize.signed_distance(triceratops, resolution=40)
    np.testing.assert_array_equal(from_trimesh.values, from_arrays.values)
    np.testing.assert_array_equal(from_lists.values, from_arrays.values)
    np.testing.assert_array_equal(from_path.values, from_arrays.values)
    assert from_path.origin == from_trimesh.origin


def test_signed_distance_is_positive_inside(triceratops):
    density = implicitize.voxelize(triceratops, resolution=40).values
    distance = implicitize.signed_distance(triceratops, resolution=40).values
    assert 0 <= density.min() and density.max() <= 1
    assert (distance[density == 1] > 0).all() and (distance[density == 0] < 0).all()


@pytest.mark.parametrize("band", [None, 2.5])
def test_exact_signed_distance_equals_the_cli(tmp_path, run, triceratops, band):
    out = tmp_path / "exact.npy"
    extra = [] if band is None else ["--band", band]
    run("sdf", triceratops, "--resolution", "40", "--exact", *extra, "-o", out)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["units"] == "mesh" and meta.get("band") == band
    volume = implicitize.signed_distance(triceratops, resolution=40, exact=True, band=band)
    assert volume.values.dtype == np.float32 and volume.values.shape == tuple(meta["dims"])
    np.testing.assert_array_equal(volume.values, np.load(out))
    assert volume.voxel_size == meta["voxel_size"] and list(volume.origin) == meta["origin"]


def test_exact_signed_distance_has_the_voxel_sign_in_mesh_units(triceratops):
    voxels = implicitize.signed_distance(triceratops, resolution=40).values
    exact = implicitize.signed_distance(triceratops, resolution=40, exact=True)
    assert (np.signbit(exact.values) == (voxels < 0)).all()
    # In voxels, near the voxel distance (which measures the voxelization).
    assert np.median(np.abs(exact.values / exact.voxel_size - voxels)) < 0.5
    banded = implicitize.signed_distance(triceratops, resolution=40, exact=True, band=2)
    limit = np.float32(2 * exact.voxel_size)
    np.testing.assert_array_equal(banded.values, np.clip(exact.values, -limit, limit))


def test_a_band_needs_exact_and_the_memory_limit_holds(triceratops):
    with pytest.raises(ValueError, match="band applies only to the exact"):
        implicitize.signed_distance(triceratops, resolution=40, band=2)
    with pytest.raises(ValueError, match="band must be a positive"):
        implicitize.signed_distance(triceratops, resolution=40, exact=True, band=0)
    with pytest.raises(MemoryError, match="memory_limit"):
        implicitize.signed_distance(triceratops, resolution=300, exact=True, memory_limit="80M")
