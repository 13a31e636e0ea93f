#!/usr/bin/env bash
# Coverage-guided fuzzing of the readers (cargo-fuzz, libFuzzer), one target for SECONDS:
#   scripts/fuzz.sh TARGET SECONDS      TARGET: obj ply stl off model npy csv png, or all
# Seeds each corpus (fuzz/corpus/TARGET, not committed) from the repository's data and small
# generated files, caps each input's memory (-rss_limit_mb, -malloc_limit_mb) and time
# (-timeout), and installs cargo-fuzz if missing. cargo-fuzz needs a nightly compiler's
# sanitizer flags; on a stable toolchain RUSTC_BOOTSTRAP=1 lets it pass them. A crash is
# saved in fuzz/artifacts/TARGET/ and the script exits non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${1:?usage: scripts/fuzz.sh TARGET|all SECONDS}"
seconds="${2:?usage: scripts/fuzz.sh TARGET|all SECONDS}"
targets=(obj ply stl off model npy csv png)
if [ "$target" = all ]; then
    for t in "${targets[@]}"; do "$0" "$t" "$seconds"; done
    exit 0
fi
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
export RUSTC_BOOTSTRAP=1

corpus="fuzz/corpus/$target"
seed() {
    mkdir -p "$corpus"
    local tmp; tmp="$(mktemp -d)"
    case "$target" in
        obj) cp data/triceratops.obj "$corpus/"
             printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n' > "$corpus/tet.obj" ;;
        off) printf 'OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n' > "$corpus/tet.off" ;;
        ply|stl|npy|png) python3 - "$target" "$corpus" <<'PY' ;;
import struct, sys, zlib
kind, out = sys.argv[1], sys.argv[2]
v = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
f = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
if kind == "ply":
    head = "ply\nformat %s 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
    open(out + "/ascii.ply", "w").write(head % "ascii" + "".join("%g %g %g\n" % p for p in v) + "".join("3 %d %d %d\n" % t for t in f))
    for name, e in (("le", "<"), ("be", ">")):
        body = b"".join(struct.pack(e + "3f", *p) for p in v) + b"".join(struct.pack(e + "B3i", 3, *t) for t in f)
        fmt = "binary_little_endian" if e == "<" else "binary_big_endian"
        open(out + "/%s.ply" % name, "wb").write((head % fmt).encode() + body)
elif kind == "stl":
    rec = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in f)
    open(out + "/binary.stl", "wb").write(b"\0" * 80 + struct.pack("<I", 4) + rec)
    facets = "".join("facet normal 0 0 0\nouter loop\n%sendloop\nendfacet\n" % "".join("vertex %g %g %g\n" % v[i] for i in t) for t in f)
    open(out + "/ascii.stl", "w").write("solid tet\n" + facets + "endsolid tet\n")
elif kind == "npy":
    for descr, code in (("<f8", "d"), ("<f4", "f")):
        header = "{'descr': '%s', 'fortran_order': False, 'shape': (4, 3), }" % descr
        header += " " * (63 - (10 + len(header)) % 64) + "\n"
        data = struct.pack("<12" + code, *[c for p in v for c in p])
        open(out + "/points-%s.npy" % code, "wb").write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + data)
elif kind == "png":
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    rows = b"".join(b"\0" + bytes(255 if (x - 8) ** 2 + (y - 8) ** 2 > 30 else 0 for x in range(16)) for y in range(16))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 16, 16, 8, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")
    open(out + "/disc.png", "wb").write(png)
PY
        model|csv)
            printf 'x,y,z,value\n0,0,0,1\n1,0,0,0\n-1,0,0,0\n0,1,0,0\n0,-1,0,0\n0,0,1,0\n0,0,-1,0\n' > "$tmp/ball.csv"
            printf 'x,y,z\n0,0,0\n1,2,3\n' > "$tmp/points.csv"
            if [ "$target" = csv ]; then cp "$tmp/ball.csv" "$tmp/points.csv" "$corpus/"; else
                cargo build --release --locked -p implicitize-cli --bin implicitize
                target/release/implicitize solve "$tmp/ball.csv" -o "$corpus/ball.json" --quiet
                target/release/implicitize csg union "$corpus/ball.json" "$corpus/ball.json" \
                    --blend 0.1 -o "$corpus/union.json" --quiet
                target/release/implicitize csg difference "$corpus/union.json" "$corpus/ball.json" \
                    -o "$corpus/difference.json" --quiet
                target/release/implicitize solve "$tmp/ball.csv" -o "$corpus/ball.imp" --quiet
                target/release/implicitize fit data/triceratops.obj --resolution 48 \
                    -o "$corpus/triceratops.imp" --quiet
            fi ;;
        *) echo "unknown target $target: one of ${targets[*]} or all" >&2; exit 2 ;;
    esac
    [ "$target" != png ] || cp docs/images/gi.png "$corpus/"
    rm -rf "$tmp"
}
[ -n "$(ls -A "$corpus" 2>/dev/null)" ] || seed

cargo fuzz run --fuzz-dir fuzz "$target" "$corpus" -- \
    -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 \
    -print_final_stats=1
