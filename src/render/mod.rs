//! Pictures of implicit surfaces and meshes: the figures of the paper (1, 3, 4 and 5).
//!
//! Two renderers share one [`Camera`] and one light, so a mesh and the implicit surface fitted
//! to it can be drawn side by side ([`Image::side_by_side`]) and compared pixel for pixel:
//!
//! - [`render_field`] draws a [`Field`] from the function itself, not from a polygonized mesh,
//!   by ray marching with root refinement and the exact analytic gradient for shading, so the
//!   picture shows what the function is (see [`march`](self::March) for the step and what it
//!   can miss). The sign convention is the crate's: inside positive, outside negative; the
//!   surface drawn is where a ray first turns positive.
//! - [`render_mesh`] draws a [`Mesh`] with a z-buffer rasterizer, flat or smooth shaded, and
//!   [`render_mesh_scalars`] colours it by a scalar per vertex, red where small and green where
//!   large (the radius of regularity of the goal surface, paper section 4.3 and figure 3).
//!
//! Pixels where nothing is are transparent, so [`Image::coverage`] is the silhouette. Positions
//! and all geometry are `f64`; pictures are 8-bit RGBA written as PNG by the `png` crate.
//! Both renderers use every core through rayon.
//!
//! ```
//! use implicitize::render::{Camera, Coloring, March, render_field};
//! use implicitize::{Aabb, DVec3, Field};
//!
//! /// A unit ball: positive inside.
//! struct Ball;
//! impl Field for Ball {
//!     fn value(&self, p: DVec3) -> f64 { 1.0 - p.length_squared() }
//!     fn gradient(&self, p: DVec3) -> DVec3 { -2.0 * p }
//! }
//!
//! let bounds = Aabb { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) };
//! let camera = Camera::framing(&bounds, 30.0, 20.0, 64, 48)?;
//! let image = render_field(&Ball, &bounds, &camera, Coloring::Plain, March::default())?;
//! assert_eq!((image.width, image.height), (64, 48));
//! assert!(image.coverage()[24 * 64 + 32]); // the centre shows the ball
//! assert!(!image.coverage()[0]); // a corner shows nothing
//! # Ok::<(), implicitize::Error>(())
//! ```

mod camera;
mod color;
mod image;
mod march;
mod raster;

pub use camera::Camera;
pub use color::Coloring;
pub use image::Image;
pub use march::{LatticeGeometry, March};
pub use raster::Shading;

use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::{Aabb, DVec3};
use crate::grid::Grid;
use crate::mesh::Mesh;
use crate::model::Model;

use color::Surface;

/// Draws the surface of `field` (where it turns from negative outside to positive inside)
/// within `bounds`, seen by `camera`, by ray marching the function with the step `settings`
/// give and refining each hit on the exact function.
///
/// Fails when `bounds` is not finite or has no extent, or `settings` is out of range.
pub fn render_field<F: Field + ?Sized>(
    field: &F,
    bounds: &Aabb,
    camera: &Camera,
    coloring: Coloring,
    settings: March,
) -> Result<Image> {
    march::march(field, bounds, camera, Surface::Colored(coloring), settings)
}

/// The fraction of a model's longest extent added to its bounds on every side before marching
/// when the model has no fit grid, so that a surface bulging a little past them is not clipped.
pub(crate) const MODEL_PAD: f64 = 0.05;

/// The box a model's function is marched through: the grid it was fitted on (its bounds and
/// margins, where the fit measured the surface), or else its bounds grown on every side by
/// `MODEL_PAD` of their longest extent.
pub fn march_bounds(model: &Model) -> Aabb {
    match model.grid() {
        Some(grid) => grid_box(grid),
        None => {
            let bounds = model.bounds();
            let pad = MODEL_PAD * bounds.size().max_element();
            Aabb { min: bounds.min - pad, max: bounds.max + pad }
        }
    }
}

/// The box the voxels of `grid` fill.
pub fn grid_box(grid: &Grid) -> Aabb {
    let [nx, ny, nz] = grid.dims;
    let last = DVec3::new(nx as f64, ny as f64, nz as f64) - 0.5;
    Aabb { min: grid.to_world(DVec3::splat(-0.5)), max: grid.to_world(last) }
}

/// Draws `mesh` seen by `camera` with a z-buffer.
///
/// Both sides of every triangle are drawn and lit alike, so open meshes and meshes of mixed
/// orientation look right. Triangles that index a missing vertex, have a non-finite corner or
/// reach behind the eye are left out.
pub fn render_mesh(mesh: &Mesh, camera: &Camera, coloring: Coloring, shading: Shading) -> Image {
    raster::rasterize(mesh, camera, Surface::Colored(coloring), shading, None)
}

/// Draws `mesh` smooth shaded and coloured by one scalar per vertex, interpolated across each
/// triangle: red at `range.0` and below, yellow halfway, green at `range.1` and above; grey
/// where a scalar is not a number.
///
/// Fails unless there is one scalar per vertex and `range` is finite with `range.0 < range.1`.
pub fn render_mesh_scalars(
    mesh: &Mesh,
    scalars: &[f32],
    range: (f32, f32),
    camera: &Camera,
) -> Result<Image> {
    if scalars.len() != mesh.vertices.len() {
        return Err(Error::invalid(
            "render",
            format!("{} scalars for a mesh of {} vertices", scalars.len(), mesh.vertices.len()),
        ));
    }
    if !(range.0.is_finite() && range.1.is_finite() && range.0 < range.1) {
        return Err(Error::invalid(
            "render",
            format!(
                "the colour range {} to {} is not an increasing finite range",
                range.0, range.1
            ),
        ));
    }
    let base = Surface::Colored(Coloring::Plain);
    Ok(raster::rasterize(mesh, camera, base, Shading::Smooth, Some((scalars, range))))
}
