#!/usr/bin/env python3
"""Makes the bunny RBF test data: 500 surface + 200 offset constraints, 2,000 random points, and
scipy's RBFInterpolator(kernel='thin_plate_spline', degree=1) values there.

Run once, from the repository root, with the peers' interpreter:
  python tests/data/make_rbf_peer_data.py MODELS_DIR/bunny.obj PEERS_DIR/peers.py
The constraints are built as `peers.py stages` builds them (trimesh.sample.sample_surface with
seed 0, offset points 4 voxels outside along the face normal, value -4 voxels) on a grid of 220
voxels along the longest axis.
"""
import subprocess, sys
import numpy as np
import trimesh

mesh_path, peers = sys.argv[1], sys.argv[2]
m = trimesh.load(mesh_path, force='mesh', process=False)
V = np.asarray(m.vertices, np.float64)
lo, hi = V.min(0), V.max(0)
h = (hi - lo).max() / (220 - 7)
pts, fi = trimesh.sample.sample_surface(m, 500, seed=0)
C = np.vstack([pts, pts[:200] + m.face_normals[fi[:200]] * 4 * h])
vals = np.concatenate([np.zeros(500), -4 * h * np.ones(200)])
with open('tests/data/bunny_constraints.csv', 'w') as f:
    f.write('x,y,z,value\n')
    for p, v in zip(C, vals):
        f.write(','.join(repr(float(x)) for x in (*p, v)) + '\n')
rng = np.random.default_rng(1)
span = hi - lo
P = lo - 0.1 * span + rng.random((2000, 3)) * 1.2 * span
np.save('tests/data/bunny_points.npy', P)
subprocess.run([sys.executable, peers, 'rbf', 'tests/data/bunny_constraints.csv',
                'tests/data/bunny_points.npy', 'tests/data/bunny_scipy_values.npy'], check=True)
