//! Meshes built from formulas, and distances between meshes.

use implicitize::{DVec3, mesh::Mesh};

/// A closed torus around the z axis with major radius `major` and tube radius `minor`,
/// triangulated with `segments` steps around the axis and `sides` around the tube, outward.
pub fn torus(major: f64, minor: f64, segments: u32, sides: u32) -> Mesh {
    let mut vertices = Vec::new();
    for s in 0..segments {
        let u = std::f64::consts::TAU * f64::from(s) / f64::from(segments);
        for t in 0..sides {
            let v = std::f64::consts::TAU * f64::from(t) / f64::from(sides);
            let r = major + minor * v.cos();
            vertices.push(DVec3::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    let at = |s: u32, t: u32| (s % segments) * sides + (t % sides);
    let mut triangles = Vec::new();
    for s in 0..segments {
        for t in 0..sides {
            let (a, b, c, d) = (at(s, t), at(s + 1, t), at(s + 1, t + 1), at(s, t + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh { vertices, triangles }
}

/// A closed UV sphere of radius `radius` at `center`, outward.
pub fn sphere(center: DVec3, radius: f64, rings: u32, segments: u32) -> Mesh {
    let mut vertices = vec![center + DVec3::Z * radius, center - DVec3::Z * radius];
    for r in 1..rings {
        let theta = std::f64::consts::PI * f64::from(r) / f64::from(rings);
        for s in 0..segments {
            let phi = std::f64::consts::TAU * f64::from(s) / f64::from(segments);
            let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            vertices.push(center + d * radius);
        }
    }
    let ring = |r: u32, s: u32| 2 + (r - 1) * segments + (s % segments);
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        triangles.push([1, ring(rings - 1, s + 1), ring(rings - 1, s)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh { vertices, triangles }
}

/// The two meshes as one (vertices not shared).
pub fn merge(a: &Mesh, b: &Mesh) -> Mesh {
    let offset = a.vertices.len() as u32;
    let mut mesh = a.clone();
    mesh.vertices.extend_from_slice(&b.vertices);
    mesh.triangles.extend(b.triangles.iter().map(|t| t.map(|i| i + offset)));
    mesh
}

/// The distance from `p` to the triangle `abc` (Ericson, Real-Time Collision Detection 5.1.5).
pub fn point_triangle_distance(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// The largest distance from a vertex of `from` to the surface of `to` (a one-sided Hausdorff
/// distance over vertices), by brute force: keep the meshes small.
pub fn max_vertex_distance(from: &Mesh, to: &Mesh) -> f64 {
    use rayon::prelude::*;
    let triangles: Vec<[DVec3; 3]> = (0..to.triangles.len()).map(|t| to.corners(t)).collect();
    from.vertices
        .par_iter()
        .map(|&p| {
            triangles.iter().map(|&t| point_triangle_distance(p, t)).fold(f64::INFINITY, f64::min)
        })
        .reduce(|| 0.0, f64::max)
}
