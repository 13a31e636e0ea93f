//! The voxel grid every volume lives on, and volumes of values over it.
//!
//! A [`Grid`] has `dims = [nx, ny, nz]` cubic voxels of side `voxel_size`; voxel `(i, j, k)`
//! is centred at `origin + voxel_size * (i, j, k)` in the mesh's own units. Volumes are stored
//! in C order (`k` fastest), the layout NumPy gives an array indexed `[i, j, k]`.
//!
//! A grid is placed around a shape's bounding box with at least [`Grid::MARGIN`] voxels of empty
//! space on every side and the shape centred, as the paper's volumes are. The 2D case of the
//! paper (figure 2) uses the same grid with `nz = 1`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3};

/// How large a grid to build around a shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Resolution {
    /// The number of voxels along the shape's longest axis, margins included; the other axes
    /// get as many as the shape needs with the same cubic voxels.
    LongestAxis(usize),
    /// An exact volume size; the voxel size is the smallest that fits the shape and margins.
    Dims([usize; 3]),
}

impl Resolution {
    /// The default voxels along the longest axis: 200, the paper's typical volume.
    pub const DEFAULT_LONGEST_AXIS: usize = 200;
}

impl Default for Resolution {
    /// [`Resolution::DEFAULT_LONGEST_AXIS`] voxels along the longest axis.
    fn default() -> Self {
        Resolution::LongestAxis(Resolution::DEFAULT_LONGEST_AXIS)
    }
}

/// A regular grid of cubic voxels in the mesh's own units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Voxels along x, y and z.
    pub dims: [usize; 3],
    /// The centre of voxel (0, 0, 0).
    pub origin: [f64; 3],
    /// The side of a voxel.
    pub voxel_size: f64,
}

impl Grid {
    /// The least number of empty voxels between the shape's bounds and the grid's edge.
    pub const MARGIN: usize = 3;

    /// The largest grid accepted along one axis (2^31 voxels in all is far beyond memory anyway).
    pub const MAX_AXIS: usize = 4096;

    /// Places a grid around `bounds` at `resolution`, the shape centred with at least
    /// [`Grid::MARGIN`] voxels of margin on every side.
    ///
    /// The voxel size is relative to the shape, so a shape scaled and moved gives the same grid
    /// in voxel terms. Fails on a resolution too small to hold the margins.
    pub fn around(bounds: &Aabb, resolution: Resolution) -> Result<Grid> {
        let size = bounds.size();
        let extent = [size.x, size.y, size.z];
        let min_dim = 2 * Self::MARGIN + 2;
        let check = |n: usize| -> Result<()> {
            if n < min_dim || n > Self::MAX_AXIS {
                return Err(Error::invalid(
                    "grid",
                    format!(
                        "{n} voxels along an axis is outside the accepted range {min_dim}..={}",
                        Self::MAX_AXIS
                    ),
                ));
            }
            Ok(())
        };
        let free = (2 * Self::MARGIN + 1) as f64;
        let (dims, voxel_size) = match resolution {
            Resolution::LongestAxis(n) => {
                check(n)?;
                let longest = extent.iter().cloned().fold(0.0, f64::max);
                let h = longest / (n as f64 - free);
                let dims = extent.map(|e| {
                    ((e / h - 1e-9).ceil().max(0.0) as usize + 2 * Self::MARGIN + 1).max(min_dim)
                });
                let mut dims = dims;
                // The longest axis gets exactly n, whatever rounding said.
                let axis = (0..3).max_by(|&a, &b| extent[a].total_cmp(&extent[b])).unwrap_or(0);
                dims[axis] = n;
                for &d in &dims {
                    check(d)?;
                }
                (dims, h)
            }
            Resolution::Dims(dims) => {
                for &d in &dims {
                    check(d)?;
                }
                let h = (0..3).map(|a| extent[a] / (dims[a] as f64 - free)).fold(0.0, f64::max);
                (dims, h)
            }
        };
        if !(voxel_size.is_finite() && voxel_size > 0.0) {
            return Err(Error::invalid("grid", "the shape has no extent to place a grid around"));
        }
        let half_span =
            DVec3::new((dims[0] - 1) as f64, (dims[1] - 1) as f64, (dims[2] - 1) as f64)
                * (voxel_size * 0.5);
        let origin = bounds.center() - half_span;
        Ok(Grid { dims, origin: origin.to_array(), voxel_size })
    }

    /// The number of voxels.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Whether the grid has no voxels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The linear (C order) index of voxel `(i, j, k)`.
    #[inline]
    pub fn index(&self, [i, j, k]: [usize; 3]) -> usize {
        (i * self.dims[1] + j) * self.dims[2] + k
    }

    /// The voxel `(i, j, k)` of a linear index.
    #[inline]
    pub fn voxel(&self, index: usize) -> [usize; 3] {
        let k = index % self.dims[2];
        let ij = index / self.dims[2];
        [ij / self.dims[1], ij % self.dims[1], k]
    }

    /// The centre of voxel `(i, j, k)` in mesh units.
    #[inline]
    pub fn position(&self, [i, j, k]: [usize; 3]) -> DVec3 {
        self.to_world(DVec3::new(i as f64, j as f64, k as f64))
    }

    /// Continuous voxel coordinates (voxel centres at whole numbers) to mesh units.
    #[inline]
    pub fn to_world(&self, g: DVec3) -> DVec3 {
        DVec3::from_array(self.origin) + g * self.voxel_size
    }

    /// Mesh units to continuous voxel coordinates (voxel centres at whole numbers).
    #[inline]
    pub fn to_grid(&self, p: DVec3) -> DVec3 {
        (p - DVec3::from_array(self.origin)) / self.voxel_size
    }

    /// Whether this is a 2D grid (one voxel deep along z), as for the paper's figure 2.
    pub fn is_2d(&self) -> bool {
        self.dims[2] == 1
    }
}

/// Values of type `T` at every voxel of a [`Grid`], in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume<T> {
    /// The grid the values live on.
    pub grid: Grid,
    /// One value per voxel, `data[grid.index([i, j, k])]`.
    pub data: Vec<T>,
}

impl<T: Clone> Volume<T> {
    /// A volume with every voxel set to `value`.
    pub fn filled(grid: Grid, value: T) -> Self {
        Volume { data: vec![value; grid.len()], grid }
    }
}

impl<T> Volume<T> {
    /// The value at voxel `(i, j, k)`.
    #[inline]
    pub fn get(&self, v: [usize; 3]) -> &T {
        &self.data[self.grid.index(v)]
    }
}

/// The version of the format of the `.json` beside a volume's `.npy`: raised when a field
/// changes meaning or goes away; fields may be added within a version.
pub const VOLUME_HEADER_VERSION: u32 = 1;

/// The unit of a volume's values, as the `.json` beside its `.npy` records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Voxels of the grid (the voxel signed distance, paper 4.2).
    Voxels,
    /// The mesh's own units (the exact signed distance).
    Mesh,
}

/// What the `.json` beside a volume's `.npy` records of its values besides the grid: their
/// unit (none for densities: `Values::default()`) and the band they are clamped to (voxels), each left out when
/// `None`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Values {
    /// The values' unit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub units: Option<Units>,
    /// The band, in voxels: values within it are exact, the others clamped to its edge.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<f64>,
}

impl Values {
    /// A signed distance in voxels, unclamped.
    pub const VOXELS: Values = Values { units: Some(Units::Voxels), band: None };
}

impl Volume<f32> {
    /// Writes the volume as a float32 NumPy array indexed `[i, j, k]` (C order) at `path`, and
    /// the grid and `values` as JSON (`{"version", "dims", "origin", "voxel_size"}` and, when
    /// given, `"units"` and `"band"`; `version` is [`VOLUME_HEADER_VERSION`]) beside it, with `.json` for `.npy`; each file atomically
    /// ([`crate::output`]).
    pub fn save_npy(&self, path: &Path, values: &Values) -> Result<()> {
        #[derive(Serialize)]
        struct Header<'a> {
            version: u32,
            #[serde(flatten)]
            grid: &'a Grid,
            #[serde(flatten)]
            values: &'a Values,
        }
        let shape = self.grid.dims.map(|d| d as u64);
        crate::npy::write(path, &shape, &self.data)?;
        let json_path = path.with_extension("json");
        let header = Header { version: VOLUME_HEADER_VERSION, grid: &self.grid, values };
        let json = serde_json::to_string_pretty(&header).expect("a grid always serializes");
        crate::output::write_bytes(&json_path, (json + "\n").as_bytes())
    }
}
