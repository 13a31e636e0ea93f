//! Helpers shared by the tests, benchmarks and examples of `implicitize` and of its command
//! (`crates/implicitize-cli`): the repository's data, meshes built from formulas, hostile
//! meshes, thin-walled and open shells, models solved from analytic constraints, grey pictures,
//! mesh topology and WGSL validation.
//!
//! Not published: both crates take it as a dev-dependency by path.

pub mod data;
pub mod hostile;
pub mod meshes;
pub mod models;
pub mod pictures;
pub mod points;
pub mod shells;
pub mod topology;
pub mod wgsl;
