//! # implicitize
//!
//! Turns a polygon mesh into a compact, smooth variational implicit surface, following
//! Morse, Yoo, Rheingans, Chen and Subramanian, "Creating implicit surfaces from polygonal
//! meshes" (Graphics Interface 1999 / tech. report), and lets you use that surface.
//!
//! The pipeline flows one way, one module per stage:
//!
//! | stage | module | paper |
//! |---|---|---|
//! | read a mesh (OBJ, PLY, STL, OFF) | [`mesh`] | 3.2 |
//! | place a voxel grid | [`grid`] | 4 |
//! | voxelize: densities, robust inside/outside | [`voxelize`] | 4.1 |
//! | signed distance, boundary voxels, surface points | [`distance`] | 4.2, 5.1, 5.3 |
//! | solve and evaluate variational implicit functions | [`rbf`] | 3.1, 5.2 |
//! | save and load models | [`model`] | |
//! | error metrics E, Ew, RMS and the radius of regularity | [`metrics`] | 4.3 |
//! | the iterative fit and its report | [`fit`] | 3.2, 5 |
//! | a 2D goal from a PNG image; figure 2 of a 2D fit | [`goal2d`], [`figure2`] | figure 2 |
//! | draw fields and meshes | [`render`] | figures 1, 3-5 |
//! | extract a surface as a mesh | [`polygonize`](mod@polygonize) | 5.2, figures |
//! | combine models: union, intersection, difference | [`csg`] | 1 |
//! | morph one model into another | [`morph`] | 1, 7 |
//!
//! ## Sign convention
//! Inside is positive and outside negative, as in the paper, for every value this crate
//! returns: implicit function values and signed distance volumes alike.
#![warn(missing_docs)]

pub mod csg;
pub mod distance;
pub mod error;
pub mod field;
pub mod figure2;
pub mod fit;
pub mod geometry;
pub mod goal2d;
pub mod grid;
pub mod mesh;
pub mod metrics;
pub mod model;
pub mod morph;
pub mod npy;
pub mod polygonize;
pub mod rbf;
pub mod render;
pub mod voxelize;

pub use error::{Error, Result};
pub use field::Field;
pub use geometry::{Aabb, DVec3};
pub use grid::{Grid, Resolution, Volume};
pub use mesh::Mesh;
pub use model::Model;
pub use polygonize::{polygonize, polygonize_field};
pub use rbf::{Constraint, ConstraintKind, Implicit, Kernel};
