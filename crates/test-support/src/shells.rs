//! Thin-walled and open meshes, generated rather than committed: hollow balls whose walls are a
//! given thickness (closed, or opened by a round hole whose rim joins the two faces), an open
//! hemisphere and two parallel sheets. Used by the thin-wall tests and by the command's example
//! `shell_mesh` (for `scripts/bench-shell.sh`).

use implicitize::{DVec3, mesh::Mesh};

use super::meshes::merge;

/// The direction of latitude `theta` (from +z) and longitude `phi`.
fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// The radius of the bumpy surfaces of [`hollow_ball`] at `theta`, `phi`, for `radius` and
/// `bump`: a smooth pattern of bumps and finer ridges, as a scan would have.
fn bumpy_radius(radius: f64, bump: f64, theta: f64, phi: f64) -> f64 {
    let ridges = 0.3 * (17.0 * theta).sin() * (13.0 * phi).sin();
    radius * (1.0 + bump * ((6.0 * theta).sin() * (5.0 * phi).cos() + ridges))
}

/// A latitude-longitude surface around the origin whose radius at `(theta, phi)` is
/// `radius(theta, phi)`, outward, from the +z pole down to latitude `last` (radians from +z),
/// in `rings` bands of `segments` sectors over the whole sphere. With `last` at π it is closed
/// by the -z pole; otherwise it ends at its last ring, the ring nearest `last` from above, and
/// the index of that ring's first vertex is returned too.
fn cap(
    radius: impl Fn(f64, f64) -> f64,
    last: f64,
    rings: usize,
    segments: usize,
) -> (Mesh, Option<u32>) {
    let closed = last >= std::f64::consts::PI;
    let step = std::f64::consts::PI / rings as f64;
    let kept =
        if closed { rings - 1 } else { ((last / step).floor() as usize).clamp(1, rings - 1) };
    let point = |theta: f64, phi: f64| direction(theta, phi) * radius(theta, phi);
    let mut vertices = vec![point(0.0, 0.0)];
    for ring in 1..=kept {
        let theta = step * ring as f64;
        for s in 0..segments {
            vertices.push(point(theta, std::f64::consts::TAU * s as f64 / segments as f64));
        }
    }
    let at = |ring: usize, s: usize| (1 + (ring - 1) * segments + s % segments) as u32;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, at(1, s), at(1, s + 1)]);
        for ring in 1..kept {
            let (a, b, c, d) = (at(ring, s), at(ring + 1, s), at(ring + 1, s + 1), at(ring, s + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    if closed {
        let south = vertices.len() as u32;
        vertices.push(point(std::f64::consts::PI, 0.0));
        for s in 0..segments {
            triangles.push([south, at(kept, s + 1), at(kept, s)]);
        }
        return (Mesh { vertices, triangles }, None);
    }
    (Mesh { vertices, triangles }, Some(at(kept, 0)))
}

/// A hollow ball around the origin: a sphere of `radius` (its radius displaced by `bump` times
/// a smooth pattern of bumps and ridges; 0 for a round one) and inside it the same surface
/// `wall` nearer the centre, facing inward, so the solid is a wall `wall` thick. An `opening`
/// above 0 cuts a round hole of that half-angle (radians) around the -z pole through the wall,
/// its rim closed by a band from one face to the other, so the cavity opens to the outside and
/// the mesh stays closed. Each face has `rings` bands of `segments` sectors over the whole
/// sphere (about `2 * rings * segments` triangles).
pub fn hollow_ball(
    radius: f64,
    wall: f64,
    bump: f64,
    opening: f64,
    rings: usize,
    segments: usize,
) -> Mesh {
    let last = std::f64::consts::PI - opening;
    let (outer, outer_rim) = cap(|t, p| bumpy_radius(radius, bump, t, p), last, rings, segments);
    let (mut inner, inner_rim) =
        cap(|t, p| bumpy_radius(radius, bump, t, p) - wall, last, rings, segments);
    inner.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let offset = outer.vertices.len() as u32;
    let mut mesh = merge(&outer, &inner);
    if let (Some(o), Some(i)) = (outer_rim, inner_rim) {
        let segments = segments as u32;
        for s in 0..segments {
            let next = (s + 1) % segments;
            let (o0, o1) = (o + s, o + next);
            let (i0, i1) = (offset + i + s, offset + i + next);
            mesh.triangles.push([o1, o0, i0]);
            mesh.triangles.push([o1, i0, i1]);
        }
    }
    mesh
}

/// The upper half of a sphere of `radius` around the origin (z >= 0), a single open sheet,
/// with `rings` bands of `segments` sectors over the whole sphere.
pub fn open_hemisphere(radius: f64, rings: usize, segments: usize) -> Mesh {
    cap(|_, _| radius, std::f64::consts::FRAC_PI_2, rings, segments).0
}

/// Two unit squares parallel to the xy plane, `gap` apart along z, each `n` x `n` quads: two
/// open sheets, no solid between them.
pub fn parallel_sheets(n: usize, gap: f64) -> Mesh {
    let lower = super::hostile::sheet(n, 0.0);
    let mut upper = lower.clone();
    upper.vertices.iter_mut().for_each(|v| v.z += gap);
    merge(&lower, &upper)
}
