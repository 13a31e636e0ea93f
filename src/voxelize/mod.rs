//! Voxelization of a polygonal mesh (paper section 4.1): a density volume, 1 inside and 0
//! outside, varying continuously in between at the surface.
//!
//! # Method
//! The mesh is moved into continuous grid coordinates first (voxel centres at whole numbers,
//! f64), so the result does not depend on the mesh's units or position: a mesh scaled by 1000
//! and moved far from the origin gives the same volume, voxel for voxel.
//!
//! Points are classified as the paper does, by casting grids of parallel rays through the mesh
//! and counting crossings, but along all three axes, and with the votes of the three rays
//! combined in the spirit of Nooruddin and Turk (the paper's reference \[5\]):
//!
//! * The mesh is first re-oriented consistently (orientation propagated across manifold edges,
//!   each component keeping the orientation of most of its area, the whole turned outward if
//!   its signed volume is negative).
//! * A ray whose entries and exits balance votes by the nonzero winding rule; otherwise a ray
//!   with an even number of crossings votes by parity; a ray with an odd number of crossings
//!   passed through a hole and abstains (see `mesh::inside`).
//! * When at least two rays vote and all votes agree, that is the answer. Otherwise the
//!   generalized winding number of the re-oriented mesh decides: inside when `w > 1/2`
//!   (Jacobson et al. 2013, evaluated hierarchically as in Barill et al. 2018).
//!
//! Each voxel centre is classified this way. Voxels with a 6-neighbour of the other state are
//! then supersampled: `s^3` points on a regular sub-lattice of the voxel are classified and
//! their mean (a box filter) is the voxel's density; every other voxel gets 0 or 1.
//!
//! # Guarantees
//! * Closed manifold meshes, whatever the orientation of their triangles (any number flipped,
//!   or all): re-orientation makes every component consistent, every ray balances, and all
//!   three rays give the exact winding number, so the result is the nonzero rule, exact up to
//!   floating-point ties. Overlapping closed parts come out as their union; an inner shell that
//!   faces inward in the file stays a hollow.
//! * Closed meshes that cannot be oriented consistently (non-manifold edges with flips): rays
//!   vote by parity; where they disagree the winding number decides.
//! * Open meshes: rays through a hole abstain or disagree, and there `w > 1/2` closes the hole
//!   as a soap film spanning its rim would (the Stanford bunny comes out solid); points whose
//!   rays miss the holes are decided by the rays alone. Missing parts larger than a hole's rim
//!   can span are not recovered.
//! * Self-intersecting meshes: the nonzero rule along balanced rays (regions wound twice are
//!   inside), the winding number elsewhere.
//! * Densities lie in `[0, 1]` in multiples of `1/s^3`. Features thinner than a voxel whose
//!   centre and neighbours all fall outside them are not supersampled and may be lost, as with
//!   any sampling at the grid's resolution.
//!
//! # Where there is no trustworthy inside
//! An open mesh has no inside of its own: the winding number caps its holes, and over a large
//! opening (a car body without its floor, a sheet) it stays near one half over a large region,
//! where the answer is a guess. [`Inside::ambiguity`] measures how much of the grid that is
//! ([`Ambiguity`]): the generalized winding number on a lattice of at most 16 voxels along
//! each axis, and the fraction of those voxels where it lies within a quarter of one half.
//! Closed meshes (however nested, duplicated, non-manifold or self-intersecting: every edge
//! traversed as often in each direction once oriented) have none, and are not sampled.
//! The winding number's hierarchy is built only when a point needs it, which on closed
//! meshes is rarely.
//!
//! Work and memory: the rays cost time proportional to the mesh's projected area times `s^2`;
//! the classification is parallel over slabs of the grid (rayon). Besides the densities
//! (4 bytes a voxel), one byte a voxel holds the centres' states while voxelizing.

pub mod shell;

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::mesh::Mesh;

use crate::mesh::inside::rays::{Rays, plane_axes, vote};
use crate::mesh::inside::winding::Winding;
use crate::mesh::inside::{Votes, orient};

/// How to voxelize. The default suits the paper's volumes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[non_exhaustive]
pub struct VoxelizeOptions {
    /// Samples per voxel along each axis at the surface (odd, 1 to 15): a boundary voxel's
    /// density is the fraction of its `supersampling^3` samples inside. 1 turns supersampling
    /// off (densities are then 0 or 1). Default 3.
    pub supersampling: usize,
}

impl Default for VoxelizeOptions {
    fn default() -> Self {
        VoxelizeOptions { supersampling: 3 }
    }
}

impl VoxelizeOptions {
    /// These options with `supersampling` samples per voxel along each axis.
    pub fn with_supersampling(self, supersampling: usize) -> Self {
        VoxelizeOptions { supersampling }
    }

    /// Checks that the supersampling is odd and in 1..=15.
    ///
    /// # Errors
    /// The supersampling, named, when it is not.
    pub fn check(&self) -> Result<()> {
        let s = self.supersampling;
        if s.is_multiple_of(2) || !(1..=15).contains(&s) {
            return Err(Error::invalid(
                "voxelize",
                format!("`supersampling` must be odd and in 1..=15, not {s}"),
            ));
        }
        Ok(())
    }
}

/// A voxelized mesh: its densities and how its inside was decided.
#[derive(Debug, Clone)]
pub struct Voxelized {
    /// Densities in `[0, 1]`, 1 inside, 0 outside.
    pub density: Volume<f32>,
    /// How the inside was decided: whether the mesh is closed, and how much was guessed.
    pub inside: Inside,
}

/// How the inside of a mesh was decided: whether the mesh is closed, and how often the rays
/// could not settle a voxel centre so that the generalized winding number decided it.
///
/// On a watertight mesh the rays agree almost everywhere and both fractions are (about) 0; on
/// an open one, a high share of the grid near one half means much of the inside was decided
/// across holes, where the result is a guess.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Inside {
    /// Every edge is shared by exactly two triangles (as [`Mesh::open_edges`] counts them,
    /// after moving the mesh into grid coordinates).
    pub watertight: bool,
    /// The edges not shared by exactly two triangles.
    pub open_edges: usize,
    /// The fraction of voxel centres decided by the winding number.
    pub winding_decided: f64,
    /// The fraction of the grid whose winding number is near one half
    /// ([`Ambiguity::fraction`]).
    pub winding_near_half: f64,
    /// The sample that fraction comes from, and its warning.
    #[serde(skip)]
    pub ambiguity: Ambiguity,
}

/// How much of a grid has no trustworthy inside: voxels whose generalized winding number is
/// near one half (see the module doc). A closed mesh (every edge traversed as often in each
/// direction once oriented) has a whole winding number everywhere off its surface, so none
/// is near one half and nothing is sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ambiguity {
    /// Voxels sampled: a regular lattice of at most 16 along each axis of the grid; 0 for a
    /// closed mesh.
    pub sampled: usize,
    /// Sampled voxels whose winding number `w` has `1/4 < |w| < 3/4`.
    pub near_half: usize,
}

impl Ambiguity {
    /// Above this fraction of the grid a warning is due ([`Ambiguity::warning`]).
    pub const DOUBTFUL: f64 = 0.01;

    /// Above this fraction of the grid a fit of the solid is refused ([`Ambiguity::refusal`]):
    /// an open car body's shell has 43% of a 200 grid near one half, an open hemisphere 29%;
    /// a robot part with a few open seams, which fits, 5%.
    pub const REFUSED: f64 = 0.2;

    /// The refusal of a fit of `source`'s solid when more than [`Ambiguity::REFUSED`] of the
    /// grid has a winding number near one half: its inside would be a guess over much of the
    /// volume. The message names the fraction and what works (`shell`, or `solid` to fit the
    /// guess anyway).
    pub fn refusal(&self, source: &str) -> Option<Error> {
        (self.fraction() > Self::REFUSED).then(|| {
            Error::invalid(
                source,
                format!(
                    "the mesh is open: the winding number is near one half in {:.1}% of the \
                     grid's voxels, so its solid would be a guess there; fit its surface \
                     thickened into a shell (`shell=2`), or the guessed solid anyway (`solid`)",
                    100.0 * self.fraction()
                ),
            )
        })
    }

    /// The fraction of the grid's voxels whose winding number is near one half.
    pub fn fraction(&self) -> f64 {
        self.near_half as f64 / self.sampled.max(1) as f64
    }

    /// A warning (one line, no file name) when more than [`Ambiguity::DOUBTFUL`] of the grid
    /// has a winding number near one half, or `None`.
    pub fn warning(&self) -> Option<String> {
        (self.fraction() > Self::DOUBTFUL).then(|| {
            format!(
                "the mesh is open: the winding number is near one half in {:.1}% of the grid's \
                 voxels, where inside and outside are a guess (holes capped as a soap film \
                 would); close the mesh for a trustworthy solid, or fit its surface thickened \
                 into a shell (`shell=2`)",
                100.0 * self.fraction()
            )
        })
    }
}

/// Voxelizes `mesh` on `grid`: densities in `[0, 1]`, 1 inside, 0 outside (see the module doc
/// for the method and what it guarantees), and how the inside was decided.
///
/// # Errors
/// The mesh has no triangles, a triangle indexes a missing vertex, a coordinate is not
/// finite, the grid is empty or its voxel size is not positive, or the supersampling is not
/// odd and in 1..=15.
pub fn voxelize(mesh: &Mesh, grid: &Grid, options: &VoxelizeOptions) -> Result<Voxelized> {
    check(mesh, grid, options)?;
    let (oriented, triangles) = oriented_on(mesh, grid)?;
    let classifier = Classifier::new(&triangles, grid.dims, options.supersampling);
    let centre = classifier.centres(grid);
    let data = classifier.densities(grid, &centre);
    let ambiguity = if oriented.closed {
        Ambiguity { sampled: 0, near_half: 0 }
    } else {
        ambiguity(classifier.winding.get(), grid)
    };
    let decided = classifier.decided.into_inner();
    let inside = Inside {
        watertight: oriented.open_edges == 0,
        open_edges: oriented.open_edges,
        winding_decided: decided as f64 / grid.len() as f64,
        winding_near_half: ambiguity.fraction(),
        ambiguity,
    };
    Ok(Voxelized { density: Volume { grid: *grid, data }, inside })
}

/// How much of `grid` has a winding number near one half for `mesh`, as [`voxelize`] measures
/// it ([`Inside::ambiguity`]), without the densities: the mesh re-oriented and its winding
/// number sampled on the same lattice, so that a fit can refuse an open mesh
/// ([`Ambiguity::refusal`]) before it voxelizes it.
///
/// # Errors
/// As [`voxelize`]'s.
pub(crate) fn ambiguity_of(mesh: &Mesh, grid: &Grid) -> Result<Ambiguity> {
    check(mesh, grid, &VoxelizeOptions::default())?;
    let (oriented, triangles) = oriented_on(mesh, grid)?;
    if oriented.closed {
        return Ok(Ambiguity { sampled: 0, near_half: 0 });
    }
    Ok(ambiguity(&Winding::new(triangles), grid))
}

/// `mesh` moved into `grid`'s coordinates and re-oriented ([`orient::orient`]): how, and its
/// triangles' corners.
fn oriented_on(mesh: &Mesh, grid: &Grid) -> Result<(orient::Oriented, Vec<[DVec3; 3]>)> {
    let vertices: Vec<DVec3> = mesh.vertices.iter().map(|&p| grid.to_grid(p)).collect();
    if vertices.iter().any(|p| !p.is_finite()) {
        return Err(Error::invalid(
            "voxelize",
            "the mesh is too far from the grid for its voxel size",
        ));
    }
    let oriented = orient::orient(&vertices, &mesh.triangles);
    let triangles = oriented.triangles.iter().map(|t| t.map(|i| vertices[i as usize])).collect();
    Ok((oriented, triangles))
}

/// The winding number on a lattice of at most 16 voxels along each axis of `grid`, one
/// spacing along all three (the longest axis's sixteenth): an axis no longer than half of it
/// (a sheet's thin side on a fine grid) is sampled at its middle, so that no grid is left
/// unsampled.
fn ambiguity(winding: &Winding, grid: &Grid) -> Ambiguity {
    let stride = grid.dims.iter().max().map_or(1, |&n| n.div_ceil(16).max(1));
    let axis = |n: usize| (if stride / 2 < n { stride / 2 } else { n / 2 }..n).step_by(stride);
    let points: Vec<[usize; 3]> = axis(grid.dims[0])
        .flat_map(|i| {
            axis(grid.dims[1]).flat_map(move |j| axis(grid.dims[2]).map(move |k| [i, j, k]))
        })
        .collect();
    let near_half = points
        .par_iter()
        .filter(|v| {
            let w = winding.at(DVec3::from_array(v.map(|x| x as f64))).abs();
            w > 0.25 && w < 0.75
        })
        .count();
    Ambiguity { sampled: points.len(), near_half }
}

fn check(mesh: &Mesh, grid: &Grid, options: &VoxelizeOptions) -> Result<()> {
    options.check()?;
    if mesh.triangles.is_empty() {
        return Err(Error::invalid("voxelize", "the mesh has no triangles"));
    }
    let n = mesh.vertices.len();
    if let Some(t) = mesh.triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
        return Err(Error::invalid(
            "voxelize",
            format!("triangle {t} refers to a vertex beyond the {n} vertices"),
        ));
    }
    if let Some(v) = mesh.vertices.iter().position(|p| !p.is_finite()) {
        return Err(Error::invalid(
            "voxelize",
            format!("vertex {v} has a coordinate that is not a finite number"),
        ));
    }
    if grid.is_empty() || !(grid.voxel_size.is_finite() && grid.voxel_size > 0.0) {
        return Err(Error::invalid("voxelize", "the grid has no voxels or no positive voxel size"));
    }
    if grid.dims.iter().any(|&d| d > Grid::MAX_AXIS) {
        return Err(Error::invalid(
            "voxelize",
            format!("the grid exceeds {} voxels along an axis", Grid::MAX_AXIS),
        ));
    }
    Ok(())
}

/// Whether a 6-neighbour of `voxel` has the other state.
fn at_surface(grid: &Grid, centre: &[bool], voxel: [usize; 3]) -> bool {
    let me = centre[grid.index(voxel)];
    (0..3).any(|axis| {
        let below = voxel[axis] > 0 && {
            let mut n = voxel;
            n[axis] -= 1;
            centre[grid.index(n)] != me
        };
        let above = voxel[axis] + 1 < grid.dims[axis] && {
            let mut n = voxel;
            n[axis] += 1;
            centre[grid.index(n)] != me
        };
        below || above
    })
}

/// The winding number's hierarchy, built when a point first needs it: on a closed mesh the
/// rays settle (nearly) every point, and building it for millions of triangles takes seconds.
struct LazyWinding<'a> {
    triangles: &'a [[DVec3; 3]],
    tree: OnceLock<Winding>,
}

impl LazyWinding<'_> {
    fn get(&self) -> &Winding {
        self.tree.get_or_init(|| Winding::new(self.triangles.to_vec()))
    }
}

/// Classifies points of the voxels' sub-lattices: sample `b` (0..s) along an axis of voxel `i`
/// lies at grid coordinate `i + (b - h) / s`, `h = (s - 1) / 2`.
struct Classifier<'a> {
    rays: [Rays; 3],
    winding: LazyWinding<'a>,
    s: usize,
    /// The voxel centres the winding number decided.
    decided: AtomicUsize,
}

impl<'a> Classifier<'a> {
    /// Casts the rays along the three axes through `triangles` (grid coordinates).
    fn new(triangles: &'a [[DVec3; 3]], dims: [usize; 3], s: usize) -> Classifier<'a> {
        let cast = |axis| Rays::cast(axis, triangles, dims, s);
        let (x, (y, z)) = rayon::join(|| cast(0), || rayon::join(|| cast(1), || cast(2)));
        let winding = LazyWinding { triangles, tree: OnceLock::new() };
        Classifier { rays: [x, y, z], winding, s, decided: AtomicUsize::new(0) }
    }

    /// Whether each voxel centre of `grid` is inside.
    fn centres(&self, grid: &Grid) -> Vec<bool> {
        let [_, ny, nz] = grid.dims;
        let mut centre = vec![false; grid.len()];
        centre.par_chunks_mut(ny * nz).enumerate().for_each(|(i, slab)| {
            for j in 0..ny {
                for k in 0..nz {
                    slab[j * nz + k] = self.centre_inside([i, j, k]);
                }
            }
        });
        centre
    }

    /// The densities: supersampled where a voxel's centre differs from a 6-neighbour's, the
    /// centre's state elsewhere.
    fn densities(&self, grid: &Grid, centre: &[bool]) -> Vec<f32> {
        let [_, ny, nz] = grid.dims;
        let mut data = vec![0.0f32; grid.len()];
        data.par_chunks_mut(ny * nz).enumerate().for_each(|(i, slab)| {
            for j in 0..ny {
                for k in 0..nz {
                    let voxel = [i, j, k];
                    slab[j * nz + k] = if at_surface(grid, centre, voxel) {
                        self.density(voxel)
                    } else {
                        f32::from(u8::from(centre[grid.index(voxel)]))
                    };
                }
            }
        });
        data
    }

    /// Whether `p` (grid coordinates) is inside, given the rays' votes there: their verdict,
    /// or the winding number where they are too few or disagree.
    fn decide(&self, votes: Votes, p: DVec3) -> bool {
        votes.verdict().unwrap_or_else(|| self.winding.get().at(p) > 0.5)
    }

    /// Whether the centre of `voxel` is inside.
    fn centre_inside(&self, voxel: [usize; 3]) -> bool {
        let h = (self.s - 1) / 2;
        let centre_ray = h * self.s + h;
        let mut votes = Votes::default();
        for (axis, rays) in self.rays.iter().enumerate() {
            let (u, v) = plane_axes(axis);
            let hits = rays.ray(voxel[u], voxel[v], centre_ray);
            votes.add(vote(hits, voxel[axis] as f64));
        }
        votes.verdict().unwrap_or_else(|| {
            let w = self.winding.get().at(DVec3::from_array(voxel.map(|x| x as f64)));
            self.decided.fetch_add(1, Ordering::Relaxed);
            w > 0.5
        })
    }

    /// The offset of sub-sample `b` from its voxel's centre.
    fn offset(&self, b: usize) -> f64 {
        (b as f64 - ((self.s - 1) / 2) as f64) / self.s as f64
    }

    /// The fraction of the voxel's `s^3` samples inside.
    fn density(&self, voxel: [usize; 3]) -> f32 {
        let s = self.s;
        let mut votes = vec![Votes::default(); s * s * s];
        for (axis, rays) in self.rays.iter().enumerate() {
            let (u, v) = plane_axes(axis);
            for bu in 0..s {
                for bv in 0..s {
                    let hits = rays.ray(voxel[u], voxel[v], bu * s + bv);
                    for ba in 0..s {
                        let mut b = [0; 3];
                        (b[axis], b[u], b[v]) = (ba, bu, bv);
                        let x = voxel[axis] as f64 + self.offset(ba);
                        votes[(b[0] * s + b[1]) * s + b[2]].add(vote(hits, x));
                    }
                }
            }
        }
        let mut count = 0usize;
        for (n, &v) in votes.iter().enumerate() {
            let b = [n / (s * s), n / s % s, n % s];
            let p = DVec3::from_array(std::array::from_fn(|a| voxel[a] as f64 + self.offset(b[a])));
            count += usize::from(self.decide(v, p));
        }
        count as f32 / (s * s * s) as f32
    }
}
