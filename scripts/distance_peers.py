"""The peers of `implicitize distance` and `sdf --exact`, one whole process per call, for
scripts/bench-distance.sh. Run with the interpreter ../shared/bench/setup-peers.sh prints.

  distance_peers.py points MESH N OUT.npy        N random points in the mesh's box padded by 10%
                                                 of its size on each side (seed 0)
  distance_peers.py grid GRID.json OUT.npy       the voxel centres of an `sdf` grid, in the order
                                                 of its .npy ([i, j, k], k fastest)
  distance_peers.py open3d MESH P.npy OUT.npy    Open3D's RaycastingScene: build and
                                                 compute_signed_distance (f32, ray-parity sign)
  distance_peers.py libigl MESH P.npy OUT.npy    libigl's signed_distance, f64, sign by the fast
                                                 winding number
  distance_peers.py reference MESH P.npy OUT.npy libigl's exact unsigned f64 distance (its
                                                 point_mesh_squared_distance)
  distance_peers.py open-meshes MESH DIR         open and broken variants of a closed MESH in DIR:
                                                 cup.ply (an open-topped cup), no-base.ply (MESH
                                                 with its lowest 10% cut off), flipped.ply (every
                                                 face reversed), overlapping.ply (two copies, the
                                                 second moved by a quarter of the box), each with
                                                 NAME.points.npy (200,000 points in the padded box)
                                                 and NAME.truth.npy (inside by the exact winding
                                                 number of the mesh as made, before any flip)
  distance_peers.py agreement OURS.npy PEER.npy TRUTH.npy REF.npy DIAG
                                                 the fractions of points at least 1% of the
                                                 diagonal from the surface (by REF) on whose side
                                                 OURS and PEER agree with TRUTH
  distance_peers.py compare OURS.npy PEER.npy DIAG
                                                 largest |ours - peer| over the box diagonal, and
                                                 the fraction whose signs agree

Every distance written is in mesh units with implicitize's sign: positive inside (the peers'
own convention, negative inside, is flipped on writing). Each call prints one JSON line with its
own timings.
"""
import json
import sys
import time

import numpy as np


def load(path):
    import trimesh
    m = trimesh.load(path, force="mesh", process=False)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def cmd_points(mesh, n, out):
    V, _ = load(mesh)
    lo, hi = V.min(0), V.max(0)
    pad = 0.1 * (hi - lo)
    rng = np.random.default_rng(0)
    P = rng.uniform(lo - pad, hi + pad, size=(int(n), 3))
    np.save(out, P)
    print(json.dumps({"points": int(n), "diagonal": float(np.linalg.norm(hi - lo))}))


def cmd_grid(grid_json, out):
    g = json.load(open(grid_json))
    dims, origin, h = g["dims"], np.array(g["origin"]), g["voxel_size"]
    axes = [origin[i] + h * np.arange(dims[i]) for i in range(3)]
    P = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    np.save(out, P)
    print(json.dumps({"points": len(P)}))


def cmd_open3d(mesh, points, out):
    import open3d as o3d
    V, F = load(mesh)
    P = np.load(points).astype(np.float32)
    t = time.perf_counter()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    built = time.perf_counter() - t
    d = scene.compute_signed_distance(o3d.core.Tensor(P)).numpy()
    np.save(out, -d.astype(np.float64))
    print(json.dumps({"build_s": built, "build_and_query_s": time.perf_counter() - t}))


def cmd_libigl(mesh, points, out):
    import igl
    V, F = load(mesh)
    P = np.load(points).astype(np.float64)
    t = time.perf_counter()
    d, _, _, _ = igl.signed_distance(P, V, F, igl.SignedDistanceType.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)
    np.save(out, -d)
    print(json.dumps({"build_and_query_s": time.perf_counter() - t}))


def cmd_reference(mesh, points, out):
    import igl
    V, F = load(mesh)
    P = np.load(points).astype(np.float64)
    d2, _, _ = igl.point_mesh_squared_distance(P, V, F)
    np.save(out, np.sqrt(d2))


def lathe(profile, segments=96):
    """The surface swept by the (radius, height) polyline `profile` about the z axis."""
    angles = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    V = np.array([[r * np.cos(a), r * np.sin(a), z] for r, z in profile for a in angles])
    F = []
    for i in range(len(profile) - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            F += [[a, b, d], [a, d, c]]
    return V, np.array(F, np.int64)


def cmd_open_meshes(mesh, directory):
    import os
    import igl
    import trimesh
    V, F = load(mesh)
    lo, hi = V.min(0), V.max(0)
    base = F[(V[F][:, :, 2].min(1) > lo[2] + 0.1 * (hi[2] - lo[2]))]
    cup = lathe([(0.0, 0.0)] + [(1.0, 0.0)] + [(1.0 + 0.2 * np.sin(t), 2.0 * t / np.pi) for t in np.linspace(0, np.pi, 24)[1:]])
    shift = 0.25 * (hi - lo)
    variants = {
        "cup": (cup, cup),
        "no-base": ((V, base), (V, base)),
        "flipped": ((V, F[:, ::-1].copy()), (V, F)),
        "overlapping": ((np.vstack([V, V + shift]), np.vstack([F, F + len(V)])),) * 2,
    }
    rng = np.random.default_rng(1)
    for name, ((mv, mf), (tv, tf)) in variants.items():
        trimesh.Trimesh(mv, mf, process=False).export(os.path.join(directory, name + ".ply"))
        lo, hi = mv.min(0), mv.max(0)
        pad = 0.1 * (hi - lo)
        P = rng.uniform(lo - pad, hi + pad, size=(200_000, 3))
        np.save(os.path.join(directory, name + ".points.npy"), P)
        np.save(os.path.join(directory, name + ".truth.npy"), igl.winding_number(tv, tf, P) >= 0.5)
        print(json.dumps({"mesh": name, "triangles": len(mf), "diagonal": float(np.linalg.norm(hi - lo))}))


def cmd_agreement(ours, peer, truth, reference, diagonal):
    a, b, t = np.load(ours) > 0, np.load(peer) > 0, np.load(truth)
    away = np.load(reference) >= 0.01 * float(diagonal)
    print(json.dumps({"points": int(away.sum()), "ours": float(np.mean(a[away] == t[away])),
                      "peer": float(np.mean(b[away] == t[away]))}))


def cmd_compare(ours, peer, diagonal):
    a, b = np.load(ours).astype(np.float64).ravel(), np.load(peer).astype(np.float64).ravel()
    diff = np.abs(np.abs(a) - np.abs(b)) / float(diagonal)
    print(json.dumps({
        "max_abs_difference_over_diagonal": float(diff.max()),
        "sign_agreement": float(np.mean((a > 0) == (b > 0))),
    }))


if __name__ == "__main__":
    commands = {"points": cmd_points, "grid": cmd_grid, "open3d": cmd_open3d,
                "libigl": cmd_libigl, "reference": cmd_reference, "compare": cmd_compare,
                "open-meshes": cmd_open_meshes, "agreement": cmd_agreement}
    if len(sys.argv) < 2 or sys.argv[1] not in commands:
        sys.exit(__doc__)
    commands[sys.argv[1]](*sys.argv[2:])
