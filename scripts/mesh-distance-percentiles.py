"""Distances between two meshes, in voxels: N points sampled uniformly by area on the first
mesh (OBJ), and with `both` on the second too, exact distances to the other mesh by
`implicitize distance` (the binary named by $IMPLICITIZE); prints percentiles.

usage: mesh-distance-percentiles.py MESH.obj MODEL_SURFACE.obj VOXEL_SIZE N [both]"""
import random, struct, subprocess, sys, os, bisect, tempfile

WORK = tempfile.mkdtemp()

def read_obj(path):
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            if line.startswith('v '):
                _, x, y, z = line.split()[:4]; v.append((float(x), float(y), float(z)))
            elif line.startswith('f '):
                idx = [int(t.split('/')[0]) for t in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(v) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    f.append((idx[0], idx[k], idx[k + 1]))
    return v, f

def sample(v, f, n, seed):
    rng = random.Random(seed)
    cum, total = [], 0.0
    for a, b, c in f:
        A, B, C = v[a], v[b], v[c]
        u = [B[i] - A[i] for i in range(3)]; w = [C[i] - A[i] for i in range(3)]
        cx = (u[1]*w[2]-u[2]*w[1], u[2]*w[0]-u[0]*w[2], u[0]*w[1]-u[1]*w[0])
        total += 0.5 * (cx[0]**2 + cx[1]**2 + cx[2]**2) ** 0.5
        cum.append(total)
    pts = []
    for _ in range(n):
        t = bisect.bisect_left(cum, rng.random() * total)
        a, b, c = f[min(t, len(f) - 1)]
        r1, r2 = rng.random(), rng.random()
        if r1 + r2 > 1: r1, r2 = 1 - r1, 1 - r2
        pts.append(tuple(v[a][i] + r1 * (v[b][i] - v[a][i]) + r2 * (v[c][i] - v[a][i]) for i in range(3)))
    return pts

def read_npy(path):
    data = open(path, 'rb').read()
    hlen = struct.unpack('<H', data[8:10])[0]
    body = data[10 + hlen:]
    return struct.unpack('<%dd' % (len(body) // 8), body)

def distances(points, mesh, tag):
    csv = os.path.join(WORK, tag + '.csv'); out = os.path.join(WORK, tag + '.npy')
    with open(csv, 'w') as fh:
        fh.write('x,y,z\n'); fh.writelines('%r,%r,%r\n' % p for p in points)
    subprocess.run([os.environ.get('IMPLICITIZE', 'implicitize'), 'distance', mesh, '--points', csv,
                    '-o', out, '--unsigned', '-q'], check=True)
    return sorted(read_npy(out))

def pct(d, q):
    return d[min(len(d) - 1, int(round(q * (len(d) - 1))))]

mesh, model_mesh, voxel, n = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
both = len(sys.argv) > 5 and sys.argv[5] == 'both'
v, f = read_obj(mesh)
d = distances(sample(v, f, n, 1), model_mesh, 'there')
rows = [('mesh -> model', d)]
if both:
    v2, f2 = read_obj(model_mesh)
    rows.append(('model -> mesh', distances(sample(v2, f2, n, 2), mesh, 'back')))
for name, d in rows:
    print('%s: 99%% %.2f  99.9%% %.2f  99.99%% %.2f  max %.2f voxels' % (
        name, pct(d, .99) / voxel, pct(d, .999) / voxel, pct(d, .9999) / voxel, d[-1] / voxel))
