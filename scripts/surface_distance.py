"""Distances between two surfaces measured independently of implicitize: points sampled by area
on one surface, exact point-to-triangle distance to the other (libigl). Used by
independent-error.sh and fit-512.sh."""
import numpy as np
import trimesh
import igl


def distances(source, target, voxel, n=50_000):
    """Distances (voxels of size `voxel`) from n points spread by area over the trimesh
    `source` to the surface of the trimesh `target`."""
    np.random.seed(0)
    points, _ = trimesh.sample.sample_surface(source, n, seed=0)
    d2, _, _ = igl.point_mesh_squared_distance(
        np.asarray(points, dtype=np.float64),
        np.asarray(target.vertices, dtype=np.float64),
        np.asarray(target.faces, dtype=np.int64))
    return np.sqrt(d2) / voxel
