//! # implicitize
//!
//! Turns a polygon mesh into a compact, smooth variational implicit surface (a few hundred
//! radial basis functions plus a linear polynomial), following Gary Yngve and Greg Turk,
//! "Creating implicit surfaces from polygonal meshes" (Georgia Institute of Technology, 1999;
//! journal version "Robust creation of implicit surfaces from polygonal meshes", IEEE
//! Transactions on Visualization and Computer Graphics, 2002), and lets you use that surface:
//! evaluate it, polygonize it, render, combine and morph it.
//!
//! ## Quick start
//! One call fits a mesh ([`pipeline::fit_mesh`], or [`pipeline::fit_file`] from a path; [`pipeline::fit`] also
//! writes the model, report and surface files); the model is a [`Field`]:
//!
//! ```
//! use implicitize::grid::Resolution;
//! use implicitize::pipeline::{MeshFitOptions, fit_mesh};
//! use implicitize::polygonize::polygonize_field;
//! use implicitize::{DVec3, Field, mesh};
//!
//! # fn main() -> implicitize::Result<()> {
//! // A mesh from a file (OBJ, PLY, STL or OFF); here the repository's triceratops.
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/triceratops.obj");
//! let (triceratops, _repairs) = mesh::read(&path)?;
//!
//! // Fit it on a small grid: 40 voxels along its longest axis, a few iterations. Options
//! // start from the defaults and change field by field.
//! let mut options = MeshFitOptions::default();
//! options.resolution = Resolution::LongestAxis(40);
//! options.fit.max_iterations = 6;
//! let fitted = fit_mesh(&triceratops, &options)?;
//! println!("E = {:.2} voxels", fitted.report.max_error_voxels);
//!
//! // Evaluate it: positive inside, negative outside, in the mesh's units.
//! let bounds = fitted.model.bounds();
//! let far = bounds.max + bounds.size();
//! assert!(fitted.model.value(far) < 0.0);
//! let values = fitted.model.values(&[bounds.center(), far]);
//! assert_eq!(values.len(), 2);
//!
//! // Polygonize its zero set on the grid it was fitted on.
//! let grid = fitted.model.grid().expect("a fitted model keeps its grid");
//! let surface = polygonize_field(&fitted.model, grid);
//! assert!(!surface.triangles.is_empty());
//! # Ok(())
//! # }
//! ```
//!
//! The signed distance volume of a mesh is [`pipeline::volume`]; every job of [`pipeline`]
//! checks its options and its memory estimate before it allocates.
//!
//! ## Guarantees
//! * **Sign:** inside is positive and outside negative, as in the paper, for every value this
//!   crate returns: implicit function values, signed distance volumes, constraint values.
//! * **Units:** positions are in the mesh's own units everywhere (constraints, bounds, model
//!   files); errors (E, Ew, RMS) are in voxels of the fit's grid, and E also in mesh units.
//!   Everything is normalized internally, so a mesh scaled by 1000 and moved far from the
//!   origin gives the same fit in voxels.
//! * **Determinism:** every random choice comes from a generator seeded by
//!   [`fit::FitOptions::seed`] (default 1): the same mesh, options and seed give the same model,
//!   bit for bit, on the same instruction set (see [`rbf::Isa`]; the environment variable
//!   `IMPLICITIZE_ISA` forces one).
//! * **Errors, not panics:** user input (files, meshes, options) never panics; every error
//!   ([`Error`]) names the file or the input and what was wrong.
//!
//! ## Limits
//! * Features thinner than a voxel are lost in voxelization. A detached piece of the current
//!   surface smaller than a coarse cube of the coarse-to-fine evaluation (4 voxels across, 8 on
//!   grids of 256 voxels or more along an axis) and more than 8 voxels from the goal's surface
//!   can be missed by that evaluation (paper 5.2), as in the paper (see
//!   `rbf::evaluate_on_grid`).
//! * Dense volumes of the whole grid are kept during a fit: memory and time grow with the
//!   grid's voxels, and the memory budget ([`memory`]) refuses a grid that does not fit.
//! * Open meshes are closed as the generalized winding number closes them.
//!
//! ## Stages
//! The pipeline flows one way, one module per stage; [`pipeline`] chains them.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | read a mesh (OBJ, PLY, STL, OFF) | [`mesh`] | 3.2 |
//! | place a voxel grid | [`grid`] | 4 |
//! | voxelize: densities, robust inside/outside | [`voxelize`] | 4.1 |
//! | signed distance on the voxels (distance transform), boundary voxels, surface points | [`edt`] | 4.2, 5.1, 5.3 |
//! | exact distance from points to a mesh, closest points, signed by the inside test | `mesh_query` | |
//! | solve and evaluate variational implicit functions | [`rbf`] | 3.1, 5.2 |
//! | error metrics E, Ew, RMS and the radius of regularity; distances between two surfaces | `metrics` | 4.3 |
//! | the iterative fit and its report | [`fit`] | 3.2, 5 |
//! | detail levels of compactly supported functions over the fit | [`rbf::MultiScale`] | |
//! | a mesh to a fitted model in one call | [`pipeline`] | |
//! | a fit's settings by their user-facing names, written once | [`pipeline::settings`] | |
//! | the shapes a model holds; save and load models | [`shape`], [`model`] | |
//! | a 2D goal from a PNG image | [`goal2d`] | 4.3 |
//! | draw fields and meshes | [`render`] | figures 1, 3-5 |
//! | GLSL and WGSL source of a model, for GPUs and the viewer | [`shader`] | |
//! | extract a surface as a mesh | [`polygonize`] | 5.2, figures |
//! | combine models: union, intersection, difference | [`shape::csg`] (a kind of [`shape`]) | 1 |
//! | morph one model into another | [`morph`] | 1, 7 |
//! | convert many meshes, resumably, with a manifest | [`batch`] | |
//! | write output files atomically | [`output`] | |
//! | estimate memory before allocating grids | [`memory`] | |
#![deny(missing_docs)]

pub mod batch;
pub mod bound;
pub mod edt;
mod error;
mod field;
pub mod fit;
mod geometry;
pub mod goal2d;
pub mod grid;
pub mod memory;
pub mod mesh;
pub(crate) mod mesh_query;
pub(crate) mod metrics;
pub mod model;
pub mod morph;
pub mod npy;
pub mod output;
pub mod pipeline;
pub mod polygonize;
pub mod rbf;
pub mod render;
pub(crate) mod sample;
pub mod shader;
pub mod shape;
pub mod voxelize;

// The stages' tests name the crate as its users do.
#[cfg(test)]
extern crate self as implicitize;
#[cfg(test)]
mod tests;

pub use error::{Error, FrontEnd, Location, Result, worded};
pub use field::Field;
pub use geometry::{Aabb, DVec3};
