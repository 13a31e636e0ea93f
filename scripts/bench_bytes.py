"""Accuracy per byte: how close to the original mesh a surface gets for the bytes it is stored
in, implicitize's models against the usual ways of shrinking a mesh. Run it through
scripts/bench-bytes.sh, which makes the peers' virtual environment.

For each model (bunny, horse, triceratops) the candidates are
- implicitize: `fit MESH -o M.imp --max-bytes N` for each budget N, `fit` with the defaults and
  `fit --resolution 512 --target-error 1`; bytes are the model file's size, and the surface
  compared is the model polygonized by `implicitize mesh M.imp --resolution 512`;
- Open3D's quadric decimation (`simplify_quadric_decimation`) to a ladder of triangle counts,
  each stored plainly (bytes = 12 per vertex + 3 indices of 2 bytes per triangle, 4 bytes from
  65,536 vertices on) and encoded by Draco (DracoPy, compression level 10, positions quantized
  to 11 and to 14 bits; bytes = the encoding's length, the surface compared its decoding);
- the whole mesh encoded by Draco at 14 bits.

Each candidate surface is compared with the original mesh by points spread by area over each
surface (stratified, scripts/surface_distance.py's `spread`, seed 0) and their exact
point-to-triangle distance to the other surface (libigl, as `distances` there measures it):
Chamfer-L1 = (mean distance original -> candidate + mean distance candidate -> original) / 2,
and p99.9 = the larger of the two one-way 99.9th percentiles, both over the original's
bounding-box diagonal, x1e3. A run of implicitize that fails (an option the binary lacks, a
budget it refuses) is recorded with the error line of its stderr.

Writes DIR/bench-bytes.md (the tables, also printed), DIR/bench-bytes.json (every row) and
DIR/bench-bytes.png (Chamfer-L1 against bytes, a panel per model); DIR/models/MODEL/ keeps the
implicitize models (--suffix picks their format). The binary is $IMPLICITIZE, else
target/release/implicitize; it is never built here.
"""
import argparse
import datetime
import itertools
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from importlib.metadata import version
from pathlib import Path

import DracoPy
import igl
import matplotlib
import numpy as np
import open3d as o3d
import trimesh

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from surface_distance import distances  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MODELS = ("bunny", "horse", "triceratops")
BUDGETS = (2000, 5000, 10000, 20000, 50000, 100000, 200000, 500000)
QUICK_BUDGETS = (2000, 10000, 50000)
FAITHFUL = "--resolution 512 --target-error 1"
TRIANGLES = (100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000)
DRACO_BITS = (11, 14)
SAMPLES = 131_072
SAMPLE_SEED = 0  # surface_distance.spread's seed, as `distances` calls it
POLYGONIZE_RESOLUTION = 512
BUDGETED, FIXED = "implicitize --max-bytes", "implicitize, fixed options"
PEERS = ("decimation, plain", "decimation + Draco 11", "decimation + Draco 14",
         "whole mesh, Draco 14")


def parse_args():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--models", nargs="+", default=list(MODELS), help="default: %(default)s")
    p.add_argument("--models-dir", type=Path, default=ROOT.parent / "shared" / "models",
                   help="folder holding MODEL.obj / MODEL.ply (default: ../shared/models)")
    p.add_argument("--out-dir", type=Path, default=ROOT / "target" / "bench-bytes")
    p.add_argument("--budgets", type=int, nargs="*",
                   help=f"fit --max-bytes budgets (default: {' '.join(map(str, BUDGETS))}; "
                        f"with --quick {' '.join(map(str, QUICK_BUDGETS))})")
    p.add_argument("--no-512", action="store_true", help=f"skip the run `fit {FAITHFUL}`")
    p.add_argument("--run", action="append", default=[], metavar="OPTIONS",
                   help="another fit to compare, by its options (repeatable), e.g. "
                        "--run '--resolution 320'")
    p.add_argument("--quick", action="store_true",
                   help=f"budgets {' '.join(map(str, QUICK_BUDGETS))} and no 512 run")
    p.add_argument("--suffix", default=".imp",
                   help="the model file's suffix, which picks its format (default: .imp)")
    p.add_argument("--triangles", type=int, nargs="+", default=list(TRIANGLES),
                   help="decimation targets, those below the mesh's count (default: %(default)s)")
    args = p.parse_args()
    if args.budgets is None:
        args.budgets = list(QUICK_BUDGETS if args.quick else BUDGETS)
    args.no_512 |= args.quick
    return args


def implicitize_runs(args):
    """(method, candidate, file stem, fit options) of every implicitize run asked for."""
    runs = [(BUDGETED, f"implicitize --max-bytes {n}", f"max-bytes-{n}", ["--max-bytes", str(n)])
            for n in args.budgets]
    fixed = ["", *([] if args.no_512 else [FAITHFUL]), *args.run]
    for k, options in enumerate(fixed):
        runs.append((FIXED, f"implicitize {options or '(defaults)'}", f"fixed-{k}",
                     shlex.split(options)))
    return runs


def header_lines(binary):
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), platform.processor())
    commit = git("rev-parse", "--short", "HEAD")
    if git("status", "--porcelain", "--untracked-files=no"):
        commit += " (working tree modified)"
    built = (datetime.datetime.fromtimestamp(binary.stat().st_mtime).isoformat(" ", "minutes")
             if binary.exists() else "missing")
    return [
        f"date: {datetime.datetime.now().isoformat(' ', 'seconds')}",
        f"machine: {cpu}, {os.cpu_count()} cores",
        f"implicitize: {binary} (built {built}), repository at {commit}",
        f"seeds: points spread with seed {SAMPLE_SEED}; fits with their default --seed (1)",
        f"peers: Open3D {o3d.__version__}, DracoPy {version('dracopy')}, "
        f"libigl {version('libigl')}, trimesh {trimesh.__version__}",
    ]


def git(*command):
    return subprocess.run(["git", "-C", str(ROOT), *command], capture_output=True,
                          text=True).stdout.strip()


def plain_bytes(mesh):
    index = 2 if len(mesh.vertices) < 65536 else 4
    return 12 * len(mesh.vertices) + 3 * index * len(mesh.faces)


def decimate(o3d_mesh, triangles):
    out = o3d_mesh.simplify_quadric_decimation(target_number_of_triangles=triangles)
    out.remove_unreferenced_vertices()
    return trimesh.Trimesh(np.asarray(out.vertices), np.asarray(out.triangles), process=False)


def draco(mesh, bits):
    """(bytes, decoded mesh) of `mesh` encoded by Draco at compression level 10."""
    encoded = DracoPy.encode(np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces),
                             quantization_bits=bits, compression_level=10)
    decoded = DracoPy.decode(encoded)
    faces = np.asarray(decoded.faces).reshape(-1, 3)
    return len(encoded), trimesh.Trimesh(np.asarray(decoded.points), faces, process=False)


def size_note(mesh):
    return f"{len(mesh.faces):,} triangles, {len(mesh.vertices):,} vertices"


def peer_candidates(original, ladder):
    """(method, candidate, bytes, surface, note) of every peer: the decimations below the
    original's triangle count, plainly and by Draco, then the whole mesh by Draco."""
    o3d_mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(original.vertices),
                                         o3d.utility.Vector3iVector(original.faces))
    for target in (t for t in ladder if t < len(original.faces)):
        small = decimate(o3d_mesh, target)
        label = f"decimation to {target:,} triangles"
        yield "decimation, plain", f"{label}, plain", plain_bytes(small), small, size_note(small)
        for bits in DRACO_BITS:
            size, decoded = draco(small, bits)
            yield f"decimation + Draco {bits}", f"{label}, Draco {bits}", size, decoded, \
                f"decoded: {size_note(decoded)}"
    size, decoded = draco(original, 14)
    yield "whole mesh, Draco 14", "whole mesh, Draco 14", size, decoded, \
        f"decoded: {size_note(decoded)}"


def run_implicitize(binary, mesh_path, options, model_path, surface_path):
    """(bytes, note) of a fit and its polygonization, or (None, the failure's stderr line)."""
    steps = [("fit", [binary, "fit", mesh_path, "-o", model_path, *options, "--quiet"]),
             ("mesh", [binary, "mesh", model_path, "-o", surface_path,
                       "--resolution", str(POLYGONIZE_RESOLUTION), "--quiet"])]
    model_path.unlink(missing_ok=True)  # a failed fit leaves no earlier run's file behind
    seconds = {}
    for name, command in steps:
        start = time.perf_counter()
        try:
            done = subprocess.run(list(map(str, command)), capture_output=True, text=True)
        except OSError as error:
            return None, f"{name} failed: {error}"
        seconds[name] = time.perf_counter() - start
        if done.returncode:
            return None, f"{name} failed: {failure_line(done)}"
    note = f"fit {seconds['fit']:.1f} s, mesh {seconds['mesh']:.1f} s"
    return model_path.stat().st_size, note


def failure_line(done):
    """The line of a failed process's stderr that says why: its first error line (clap ends
    its message with a hint), else its last line."""
    lines = [line.strip() for line in done.stderr.splitlines() if line.strip()]
    errors = [line for line in lines if line.lower().startswith("error")]
    if errors:
        return errors[0]
    return lines[-1] if lines else f"exit status {done.returncode}"


def implicitize_candidates(binary, mesh_path, runs, model_dir, suffix):
    """(method, candidate, bytes, surface or None, note) of every implicitize run."""
    with tempfile.TemporaryDirectory() as work:
        for method, candidate, stem, options in runs:
            surface_path = Path(work) / f"{stem}.ply"
            size, note = run_implicitize(binary, mesh_path, options, model_dir / f"{stem}{suffix}",
                                         surface_path)
            surface = None
            if size is not None:
                surface = trimesh.load(surface_path, force="mesh", process=False)
                note = f"{size_note(surface)} at {POLYGONIZE_RESOLUTION}; {note}"
                surface_path.unlink()
            yield method, candidate, size, surface, note


def measure(original, diagonal, surface):
    """The two-way distances between the original and a candidate, in thousandths of the
    original's bounding-box diagonal."""
    there = one_way(distances(original, surface, diagonal / 1e3, SAMPLES))
    back = one_way(distances(surface, original, diagonal / 1e3, SAMPLES))
    return {
        "chamfer_l1_x1e3": (there["mean_x1e3"] + back["mean_x1e3"]) / 2,
        "p99_9_x1e3": max(there["p99_9_x1e3"], back["p99_9_x1e3"]),
        "original_to_candidate": there,
        "candidate_to_original": back,
    }


def one_way(d):
    return {"mean_x1e3": d.mean(), "p99_9_x1e3": np.percentile(d, 99.9), "max_x1e3": d.max()}


def bench_model(name, mesh_path, args, binary):
    """Every row of one model: its candidates, measured."""
    original = trimesh.load(mesh_path, force="mesh")
    diagonal = float(np.linalg.norm(original.extents))
    model_dir = args.out_dir / "models" / name
    model_dir.mkdir(parents=True, exist_ok=True)
    candidates = itertools.chain(   # one candidate surface in memory at a time
        implicitize_candidates(binary, mesh_path, implicitize_runs(args), model_dir, args.suffix),
        peer_candidates(original, args.triangles))
    rows = []
    for method, candidate, size, surface, note in candidates:
        row = {"model": name, "method": method, "candidate": candidate, "bytes": size,
               "notes": note, "diagonal": diagonal}
        if surface is not None:
            row.update(measure(original, diagonal, surface))
        rows.append(row)
        measured = "" if surface is None else \
            f"{size:,} bytes, Chamfer-L1 x1e3 {row['chamfer_l1_x1e3']:.3g}; "
        print(f"  {name}: {candidate}: {measured}{note}", file=sys.stderr)
    return original, diagonal, rows


def number(x):
    return "—" if x is None else f"{x:.3g}"


def table(name, original, diagonal, rows):
    lines = [
        f"### {name}: {size_note(original)}, plainly {plain_bytes(original):,} bytes, "
        f"bounding-box diagonal D = {diagonal:.4g}",
        "",
        f"Chamfer-L1 = (mean distance original -> candidate + mean distance candidate -> "
        f"original) / 2 over {SAMPLES:,} points spread on each; p99.9 = the larger one-way "
        f"99.9th percentile; both in thousandths of D, exact point-to-triangle distances "
        f"(libigl).",
        "",
        "| candidate | bytes | Chamfer-L1 x1e3 | p99.9 x1e3 | notes |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        size = "—" if row["bytes"] is None else f"{row['bytes']:,}"
        notes = row["notes"].replace("|", "\\|")
        lines.append(f"| {row['candidate']} | {size} | {number(row.get('chamfer_l1_x1e3'))} | "
                     f"{number(row.get('p99_9_x1e3'))} | {notes} |")
    if name == "bunny":
        lines += ["", "The bunny is open at its base and implicitize's surfaces are closed: their "
                  "cap over the base counts in the candidate -> original half (the JSON has "
                  "each way)."]
    return "\n".join(lines)


def plot(results, path):
    fig, axes = plt.subplots(1, len(results), figsize=(5.5 * len(results), 4.5), squeeze=False)
    for ax, (name, rows) in zip(axes[0], results.items()):
        measured = [r for r in rows if "chamfer_l1_x1e3" in r]
        for method in (BUDGETED, *PEERS):
            line = sorted((r for r in measured if r["method"] == method), key=lambda r: r["bytes"])
            if line:
                ax.plot([r["bytes"] for r in line], [r["chamfer_l1_x1e3"] for r in line],
                        "o-" if len(line) > 1 else "D", label=method, markersize=4)
        fixed = [r for r in measured if r["method"] == FIXED]
        for marker, r in zip(itertools.cycle("s^vP*X"), fixed):
            ax.plot(r["bytes"], r["chamfer_l1_x1e3"], marker, color="black", markersize=7,
                    label=r["candidate"])
        sizes = [r["bytes"] for r in measured]
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(min([1e3, *sizes]) / 1.2, max([1e6, *sizes]) * 1.2)
        ax.set_xlabel("bytes")
        ax.set_ylabel("Chamfer-L1 (thousandths of the diagonal)")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def find_mesh(models_dir, name):
    found = sorted(p for p in models_dir.glob(f"{name}.*")
                   if p.suffix in (".obj", ".ply", ".stl", ".off"))
    if not found:
        sys.exit(f"no mesh {name}.obj/.ply/.stl/.off in {models_dir}")
    return found[0]


def main():
    args = parse_args()
    binary = Path(os.environ.get("IMPLICITIZE", ROOT / "target" / "release" / "implicitize")
                  ).resolve()
    args.out_dir.mkdir(parents=True, exist_ok=True)
    header = header_lines(binary)
    print("\n".join(header), end="\n\n", flush=True)
    tables, results = [], {}
    for name in args.models:
        original, diagonal, rows = bench_model(name, find_mesh(args.models_dir, name), args,
                                               binary)
        results[name] = rows
        tables.append(table(name, original, diagonal, rows))
        print(tables[-1], end="\n\n", flush=True)
    (args.out_dir / "bench-bytes.md").write_text("\n".join(header) + "\n\n" +
                                                  "\n\n".join(tables) + "\n")
    (args.out_dir / "bench-bytes.json").write_text(json.dumps(
        {"header": header, "rows": [r for rows in results.values() for r in rows]}, indent=1))
    plot(results, args.out_dir / "bench-bytes.png")
    print(f"wrote {args.out_dir}/bench-bytes.md, .json and .png", file=sys.stderr)


if __name__ == "__main__":
    main()
