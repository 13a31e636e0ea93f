"""Distances between two surfaces measured independently of implicitize: points spread by area
on one surface, exact point-to-triangle distance to the other (libigl). Used by
independent-error.sh and fit-512.sh."""
import numpy as np
import igl


def spread(mesh, n, seed=0):
    """n points spread by area over the trimesh `mesh`, stratified (systematic sampling): the
    faces laid end to end by area in the file's order, a point at each area (offset + k) * A / n
    for an offset uniform in [0, 1) drawn from `seed`, uniform on its face. Every face gets its
    expected number of points to within one, so a percentile varies far less from seed to seed
    than with independent draws."""
    rng = np.random.default_rng(seed)
    corners = np.asarray(mesh.triangles, dtype=np.float64)
    ends = np.cumsum(mesh.area_faces)
    at = (rng.random() + np.arange(n)) * (ends[-1] / n)
    face = np.minimum(np.searchsorted(ends, at, side="right"), len(ends) - 1)
    s = np.sqrt(rng.random(n))[:, None]
    v = rng.random(n)[:, None]
    a, b, c = (corners[face, k] for k in range(3))
    return a * (1 - s) + b * (s * (1 - v)) + c * (s * v)


def distances(source, target, voxel, n=50_000):
    """Distances (voxels of size `voxel`) from n points spread by area over the trimesh
    `source` (`spread`) to the surface of the trimesh `target`."""
    d2, _, _ = igl.point_mesh_squared_distance(
        spread(source, n),
        np.asarray(target.vertices, dtype=np.float64),
        np.asarray(target.faces, dtype=np.int64))
    return np.sqrt(d2) / voxel
