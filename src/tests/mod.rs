//! The library's tests of its stages end to end, one file per stage or theme: they reach
//! below the public API (the distance transform, the exact distance's queries, the goal of a
//! fit, the grid evaluation), so they are compiled with the crate rather than beside it.
//!
//! The helpers they share with the command's tests (the repository's data, meshes built from
//! formulas, hostile meshes, shells, models, topology and WGSL checks) are the
//! `implicitize-test-support` crate's source, compiled here as the module [`support`] so that
//! its meshes and models are this crate's types (`extern crate self as implicitize` in
//! lib.rs lets both name the crate `implicitize`).

// The tests set options field by field after `default()`, as code outside the crate must
// (the option structs are `#[non_exhaustive]`), so that they read as the users' code does.
#![allow(clippy::field_reassign_with_default)]

#[path = "../../crates/test-support/src/lib.rs"]
#[allow(dead_code)] // Some helpers serve only the command's tests.
pub(crate) mod support;

mod csg;
mod edt;
mod exact_volume;
mod fit;
mod goal2d;
mod levels;
mod mesh_formats;
mod mesh_fuzz;
mod mesh_query;
mod metrics;
mod model;
mod model_fuzz;
mod morph;
mod polygonize;
mod rbf;
mod render;
mod sample;
mod shader;
mod slits;
mod thin_walls;
mod voxelize;
