"""A large closed mesh with fine relief, for the benchmarks of detail levels (issue 31's "mesh of
several hundred thousand triangles with fine relief"): the paper's horse, each triangle split
into four (twice: 1,551,456 triangles; once with --once: 387,864), its vertices moved along
their normals by a pattern of scales, bumps WAVELENGTH voxels of a RESOLUTION grid apart and
AMPLITUDE voxels high. At 512, 12 voxels apart and 1.5 high: finer than a fit at the defaults
can hold (its voxels are 2.5 of these), coarse enough that a voxel of 512 sees them.

usage: relief-mesh.py OUT.obj [--once] [--resolution 512] [--wavelength 12] [--amplitude 1.5]
Needs numpy and trimesh (../shared/bench/setup-peers.sh makes the environment)."""
import argparse

import numpy as np
import trimesh

parser = argparse.ArgumentParser()
parser.add_argument("out")
parser.add_argument("--mesh", default="../shared/models/horse.ply")
parser.add_argument("--once", action="store_true")
parser.add_argument("--resolution", type=int, default=512)
parser.add_argument("--wavelength", type=float, default=12.0)
parser.add_argument("--amplitude", type=float, default=1.5)
args = parser.parse_args()

mesh = trimesh.load(args.mesh, force="mesh")
for _ in range(1 if args.once else 2):
    mesh = mesh.subdivide()
voxel = mesh.extents.max() / args.resolution
k = 2 * np.pi / (args.wavelength * voxel)
p = mesh.vertices
# Scales: the product of three sines is a lattice of bumps and dimples; the absolute value
# makes each a raised scale with a crease between neighbours.
relief = np.abs(np.sin(k * p[:, 0]) * np.sin(k * p[:, 1]) * np.sin(k * p[:, 2])) ** 0.5
moved = p + mesh.vertex_normals * (args.amplitude * voxel * relief)[:, None]
out = trimesh.Trimesh(moved, mesh.faces, process=False)
out.export(args.out)
print(f"{args.out}: {len(out.faces)} triangles, voxel of the {args.resolution} grid {voxel:.3g}, "
      f"watertight {out.is_watertight}")
