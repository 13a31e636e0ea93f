//! Hostile meshes, generated rather than committed: a finely subdivided displaced sphere,
//! nested shells, duplicated and zero-area faces, non-manifold edges, self-intersecting parts,
//! an open sheet and a car-body-like open shell. Used by the command's `tests/cli_hostile.rs`
//! and by its example `hostile_mesh` (for `scripts/bench-hostile.sh`).

use implicitize::{DVec3, mesh::Mesh};

use super::meshes::merge;

/// A sphere of `radius` around `centre` on a latitude-longitude grid of `rings` bands and
/// `segments` sectors (`2 * segments * (rings - 1)` triangles), its radius displaced by
/// `bump` times a smooth pattern of bumps, facing outward or (`inward`) inward.
pub fn bumpy_sphere(
    centre: DVec3,
    radius: f64,
    bump: f64,
    rings: usize,
    segments: usize,
    inward: bool,
) -> Mesh {
    let point = |theta: f64, phi: f64| {
        let r = radius * (1.0 + bump * (6.0 * theta).sin() * (5.0 * phi).cos());
        centre + r * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    };
    let mut vertices = vec![point(0.0, 0.0), point(std::f64::consts::PI, 0.0)];
    for ring in 1..rings {
        let theta = std::f64::consts::PI * ring as f64 / rings as f64;
        for s in 0..segments {
            vertices.push(point(theta, std::f64::consts::TAU * s as f64 / segments as f64));
        }
    }
    let at = |ring: usize, s: usize| (2 + (ring - 1) * segments + s % segments) as u32;
    let mut triangles = Vec::with_capacity(2 * segments * (rings - 1));
    for s in 0..segments {
        triangles.push([0, at(1, s), at(1, s + 1)]);
        triangles.push([1, at(rings - 1, s + 1), at(rings - 1, s)]);
        for ring in 1..rings - 1 {
            let (a, b, c, d) = (at(ring, s), at(ring + 1, s), at(ring + 1, s + 1), at(ring, s + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    if inward {
        triangles.iter_mut().for_each(|t| t.swap(1, 2));
    }
    Mesh { vertices, triangles }
}

/// The six faces of an axis-aligned box, outward, as `(corner indices)` into its 8 corners
/// (corner `c` at `min + size * (c & 1, c >> 1 & 1, c >> 2 & 1)`).
const BOX_FACES: [[u32; 4]; 6] =
    [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];

/// An axis-aligned box from `min` of `size`, outward, with the faces of `BOX_FACES` that
/// `keep` selects (the floor, z = min, is face 0).
pub fn open_box(min: DVec3, size: DVec3, keep: impl Fn(usize) -> bool) -> Mesh {
    let vertices = (0..8)
        .map(|c| min + size * DVec3::new((c & 1) as f64, (c >> 1 & 1) as f64, (c >> 2 & 1) as f64))
        .collect();
    let triangles = BOX_FACES
        .iter()
        .enumerate()
        .filter(|&(f, _)| keep(f))
        .flat_map(|(_, &[a, b, c, d])| [[a, b, c], [a, c, d]])
        .collect();
    Mesh { vertices, triangles }
}

/// A closed axis-aligned box.
pub fn cube(min: DVec3, size: f64) -> Mesh {
    open_box(min, DVec3::splat(size), |_| true)
}

/// A unit cube whose every face is there twice, plus zero-area faces: a repeated corner and
/// three collinear corners.
pub fn duplicated_and_zero_area() -> Mesh {
    let mut mesh = cube(DVec3::ZERO, 1.0);
    let copies = mesh.triangles.clone();
    mesh.triangles.extend(copies);
    mesh.vertices.push(DVec3::new(0.5, 0.0, 0.0));
    mesh.triangles.push([0, 0, 1]);
    mesh.triangles.push([0, 8, 1]);
    mesh
}

/// Two unit cubes that share one edge (x = 1, y = 1) through the same two vertices: four
/// triangles meet at each of that edge's sides.
pub fn non_manifold_edge() -> Mesh {
    let a = cube(DVec3::ZERO, 1.0);
    let b = cube(DVec3::new(1.0, 1.0, 0.0), 1.0);
    let mut mesh = merge(&a, &b);
    // b's corners 0 and 4 (x = 1, y = 1, z = 0 and 1) are a's corners 3 and 7.
    for t in mesh.triangles.iter_mut() {
        for i in t.iter_mut() {
            *i = match *i {
                8 => 3,
                12 => 7,
                other => other,
            };
        }
    }
    mesh
}

/// Two cubes of side 2 passing through each other (overlap [1, 2]^3), not trimmed.
pub fn self_intersecting() -> Mesh {
    merge(&cube(DVec3::ZERO, 2.0), &cube(DVec3::ONE, 2.0))
}

/// A square sheet, `n` x `n` quads, flat (`sag = 0`) or sagging by `sag` at its centre.
pub fn sheet(n: usize, sag: f64) -> Mesh {
    let mut vertices = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            let z = sag * (1.0 - 4.0 * (x - 0.5).powi(2)) * (1.0 - 4.0 * (y - 0.5).powi(2));
            vertices.push(DVec3::new(x, y, z));
        }
    }
    let at = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh { vertices, triangles }
}

/// A car body's shell: a long box without its floor (open below), and a cabin on top without
/// its floor either, so the two overlap like panels, not solids.
pub fn car_body() -> Mesh {
    let body = open_box(DVec3::ZERO, DVec3::new(4.0, 1.8, 0.8), |f| f != 0);
    let cabin = open_box(DVec3::new(1.2, 0.1, 0.8), DVec3::new(1.8, 1.6, 0.6), |f| f != 0);
    merge(&body, &cabin)
}
