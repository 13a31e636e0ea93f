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
//! | extract a surface as a mesh | [`polygonize`](mod@polygonize) | 5.2, figures |
//!
//! ## Sign convention
//! Inside is positive and outside negative, as in the paper, for every value this crate
//! returns: implicit function values and signed distance volumes alike.
#![warn(missing_docs)]

pub mod error;
pub mod field;
pub mod geometry;
pub mod grid;
pub mod mesh;
pub mod npy;
pub mod polygonize;

pub use error::{Error, Result};
pub use field::Field;
pub use geometry::{Aabb, DVec3};
pub use grid::{Grid, Resolution, Volume};
pub use mesh::Mesh;
pub use polygonize::{polygonize, polygonize_field};
