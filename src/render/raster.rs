//! The z-buffer rasterizer that draws triangle meshes.
//!
//! Triangles are projected with the shared [`Camera`], a pixel is covered when its centre lies
//! inside a projected triangle, the nearest triangle wins, and depth and attributes are
//! interpolated perspective-correctly. Each pixel is shaded once, after visibility is settled.
//! The image is cut into bands of rows drawn in parallel.

use rayon::prelude::*;

use crate::geometry::DVec3;
use crate::mesh::Mesh;

use super::camera::Camera;
use super::color::{Surface, scalar_color, shade};
use super::image::Image;

/// How a mesh's normals vary across a triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shading {
    /// One normal per triangle: the facets of the mesh show.
    Flat,
    /// Vertex normals (area-weighted averages of the adjacent triangles' normals) interpolated
    /// across each triangle.
    #[default]
    Smooth,
}

/// Rows per band of the image drawn by one task.
const BAND: usize = 16;

/// Per-vertex scalars and the range the colour map spans.
pub(crate) type Scalars<'a> = (&'a [f32], (f32, f32));

/// A triangle ready to draw: its corners in pixel coordinates and depths.
struct Projected {
    triangle: usize,
    corners: [[f64; 2]; 3],
    depths: [f64; 3],
    /// Twice the signed area in pixels.
    area: f64,
}

/// The nearest surface seen at a pixel so far.
#[derive(Clone, Copy)]
struct Fragment {
    depth: f64,
    triangle: usize,
    /// Perspective-correct barycentric weights of the triangle's corners.
    weights: [f64; 3],
}

/// Draws `mesh`, coloured by `coloring` or, when given, by per-vertex scalars.
///
/// Triangles that index a missing vertex, have a non-finite corner or reach behind the eye
/// are left out, so no input makes this panic.
pub(crate) fn rasterize(
    mesh: &Mesh,
    camera: &Camera,
    surface: Surface,
    shading: Shading,
    scalars: Option<Scalars>,
) -> Image {
    let (width, height) = (camera.width(), camera.height());
    let triangles = project(mesh, camera);
    let mut bands: Vec<Vec<&Projected>> = vec![Vec::new(); height.div_ceil(BAND)];
    for t in &triangles {
        if let Some((first, last)) = rows_spanned(t, height) {
            for band in &mut bands[first / BAND..=last / BAND] {
                band.push(t);
            }
        }
    }
    let vertex_normals = (shading == Shading::Smooth).then(|| vertex_normals(mesh));
    let mut image = Image::empty(width, height);
    image.rgba.par_chunks_mut(BAND * width * 4).zip(&bands).enumerate().for_each(
        |(b, (pixels, band))| {
            let top = b * BAND;
            let rows = pixels.len() / (width * 4);
            let mut nearest: Vec<Option<Fragment>> = vec![None; rows * width];
            for t in band {
                draw(t, top, rows, width, &mut nearest);
            }
            for (i, fragment) in nearest.iter().enumerate() {
                let Some(f) = fragment else { continue };
                let (x, y) = (i % width, top + i / width);
                let corners = mesh.triangles[f.triangle].map(|v| v as usize);
                let normal = match &vertex_normals {
                    Some(normals) => {
                        let n = interpolate(f.weights, corners.map(|v| normals[v]));
                        n.try_normalize().unwrap_or_else(|| face_normal(mesh, f.triangle))
                    }
                    None => face_normal(mesh, f.triangle),
                };
                let surface = match scalars {
                    Some((values, range)) => {
                        let s = f.weights.iter().zip(corners).map(|(w, v)| w * values[v] as f64);
                        Surface::Base(scalar_color(s.sum::<f64>() as f32, range))
                    }
                    None => surface,
                };
                let pixel = shade(surface, normal, camera.ray(x, y), camera);
                pixels[i * 4..i * 4 + 4].copy_from_slice(&pixel);
            }
        },
    );
    image
}

/// The triangles that can be drawn, projected onto the image.
fn project(mesh: &Mesh, camera: &Camera) -> Vec<Projected> {
    let screen: Vec<(f64, f64, f64)> =
        mesh.vertices.par_iter().map(|&p| camera.project(p)).collect();
    let near = 1e-9 * camera.eye().abs().max_element().max(1.0);
    (0..mesh.triangles.len())
        .into_par_iter()
        .filter_map(|triangle| {
            let mut corners = [[0.0; 2]; 3];
            let mut depths = [0.0; 3];
            for (k, &v) in mesh.triangles[triangle].iter().enumerate() {
                let &(x, y, depth) = screen.get(v as usize)?;
                if !(x.is_finite() && y.is_finite() && depth > near) {
                    return None;
                }
                corners[k] = [x, y];
                depths[k] = depth;
            }
            let area = edge(corners[0], corners[1], corners[2]);
            (area != 0.0 && area.is_finite()).then_some(Projected {
                triangle,
                corners,
                depths,
                area,
            })
        })
        .collect()
}

/// The first and last rows whose pixel centres the triangle's vertical extent reaches.
fn rows_spanned(t: &Projected, height: usize) -> Option<(usize, usize)> {
    let ys = t.corners.map(|c| c[1]);
    let (lo, hi) = (ys[0].min(ys[1]).min(ys[2]), ys[0].max(ys[1]).max(ys[2]));
    let first = (lo - 0.5).ceil().max(0.0);
    let last = (hi - 0.5).floor().min(height as f64 - 1.0);
    (first <= last).then_some((first as usize, last as usize))
}

/// Twice the signed area of triangle `(a, b, p)`.
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Draws one triangle into the z-buffer of the band of `rows` rows starting at row `top`.
fn draw(t: &Projected, top: usize, rows: usize, width: usize, nearest: &mut [Option<Fragment>]) {
    let xs = t.corners.map(|c| c[0]);
    let ys = t.corners.map(|c| c[1]);
    let x0 = (xs[0].min(xs[1]).min(xs[2]) - 0.5).ceil().max(0.0) as usize;
    let x1 = (xs[0].max(xs[1]).max(xs[2]) - 0.5).floor().min(width as f64 - 1.0);
    let y0 = ((ys[0].min(ys[1]).min(ys[2]) - 0.5).ceil().max(top as f64)) as usize;
    let y1 = (ys[0].max(ys[1]).max(ys[2]) - 0.5).floor().min((top + rows) as f64 - 1.0);
    if x1 < 0.0 || y1 < 0.0 {
        return;
    }
    let [a, b, c] = t.corners;
    for y in y0..=y1 as usize {
        for x in x0..=x1 as usize {
            let p = [x as f64 + 0.5, y as f64 + 0.5];
            let screen = [edge(b, c, p) / t.area, edge(c, a, p) / t.area, edge(a, b, p) / t.area];
            if screen.iter().any(|&w| w < 0.0) {
                continue;
            }
            let inverse = [0, 1, 2].map(|k| screen[k] / t.depths[k]);
            let inverse_depth: f64 = inverse.iter().sum();
            let depth = 1.0 / inverse_depth;
            let slot = &mut nearest[(y - top) * width + x];
            if slot.is_none_or(|f| depth < f.depth) {
                let weights = inverse.map(|w| w * depth);
                *slot = Some(Fragment { depth, triangle: t.triangle, weights });
            }
        }
    }
}

fn interpolate(weights: [f64; 3], values: [DVec3; 3]) -> DVec3 {
    weights[0] * values[0] + weights[1] * values[1] + weights[2] * values[2]
}

/// The unit normal of triangle `t` by its winding (counter-clockwise seen from outside).
fn face_normal(mesh: &Mesh, t: usize) -> DVec3 {
    let [a, b, c] = mesh.corners(t);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Area-weighted vertex normals (zero for a vertex no triangle uses).
fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; mesh.vertices.len()];
    for t in &mesh.triangles {
        let Some(corners) =
            t.iter().map(|&v| mesh.vertices.get(v as usize)).collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let n = (*corners[1] - *corners[0]).cross(*corners[2] - *corners[0]);
        if n.is_finite() {
            for &v in t {
                normals[v as usize] += n;
            }
        }
    }
    normals
}
