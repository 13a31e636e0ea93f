//! The densities of a mesh's surface thickened into a shell: for open shells whose inside is
//! not defined (a car body, a single-sheet scan, a hollow print whose cavity opens to the
//! outside), the solid of the points within half a thickness `T` of the mesh, whichever side.
//!
//! Each voxel centre's unsigned distance `d` to the triangles is exact
//! (`crate::mesh_query::grid`, within a band of `T/2` plus two voxels; farther voxels are
//! outside). Its density is `1/2 + (T/2 - d) / 2h` clamped to [0, 1] (`h` the voxel size): a
//! ramp two voxels wide that crosses 1/2 exactly where `d = T/2`. Both ends of a grid edge that
//! crosses the thickened surface are within a voxel of it, on the ramp, so the goal's surface
//! points (where the densities cross 1/2 between voxel centres) lie on the thickened surface to
//! the precision of a linear interpolation of the distance along the edge.

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::grid::{Grid, Volume};
use crate::mesh_query::{self, MeshQuery};

/// A shell's thickness, in all (half on each side of the surface): in voxels of the fit's grid,
/// written as a number (`2`), or in the mesh's units, written with the suffix `u` (`0.01u`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shell {
    /// Voxels of the fit's grid.
    Voxels(f64),
    /// The mesh's units.
    Mesh(f64),
}

impl Shell {
    /// The thickness in mesh units, on a grid of voxels of `voxel_size`.
    pub fn in_mesh_units(self, voxel_size: f64) -> f64 {
        match self {
            Shell::Voxels(t) => t * voxel_size,
            Shell::Mesh(t) => t,
        }
    }

    /// Checks that the thickness is a finite number above 0.
    ///
    /// # Errors
    /// A thickness out of range, named.
    pub fn check(self) -> Result<()> {
        let (Shell::Voxels(t) | Shell::Mesh(t)) = self;
        if t.is_finite() && t > 0.0 {
            Ok(())
        } else {
            Err(Error::invalid("options", format!("`shell` must be above 0, not {self}")))
        }
    }
}

impl fmt::Display for Shell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Shell::Voxels(t) => write!(f, "{t}"),
            Shell::Mesh(t) => write!(f, "{t}u"),
        }
    }
}

impl FromStr for Shell {
    type Err = Error;

    fn from_str(text: &str) -> Result<Shell> {
        let text = text.trim();
        let (number, shell): (&str, fn(f64) -> Shell) = match text.strip_suffix('u') {
            Some(number) => (number, Shell::Mesh),
            None => (text, Shell::Voxels),
        };
        let shell = number.parse().map(shell).map_err(|_| {
            Error::invalid(
                "options",
                format!(
                    "`shell` must be a thickness in voxels (as 2) or in mesh units (as 0.01u), \
                     not {text:?}"
                ),
            )
        })?;
        shell.check()?;
        Ok(shell)
    }
}

/// The densities on `grid` of the surface of `query` thickened to `thickness` mesh units in
/// all (see the module doc), 1 inside.
pub(crate) fn densities(query: &MeshQuery, grid: &Grid, thickness: f64) -> Volume<f32> {
    let half = thickness / 2.0;
    let band = half / grid.voxel_size + 2.0;
    let mut volume =
        mesh_query::grid::signed_distance(query, Volume::filled(*grid, 0.0), Some(band));
    let h = grid.voxel_size;
    volume.data.par_iter_mut().for_each(|v| {
        let d = f64::from(v.abs());
        *v = (0.5 + (half - d) / (2.0 * h)).clamp(0.0, 1.0) as f32;
    });
    volume
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thicknesses_are_read_in_voxels_or_mesh_units() {
        assert_eq!("2".parse::<Shell>().unwrap(), Shell::Voxels(2.0));
        assert_eq!(" 0.01u".parse::<Shell>().unwrap(), Shell::Mesh(0.01));
        assert_eq!(Shell::Mesh(0.01).to_string(), "0.01u");
        for bad in ["0", "-1", "u", "2 voxels", "nan", "inf"] {
            let error = bad.parse::<Shell>().unwrap_err().to_string();
            assert!(error.starts_with("options: `shell` must be"), "{bad}: {error}");
        }
        assert_eq!(Shell::Voxels(2.0).in_mesh_units(0.5), 1.0);
    }
}
