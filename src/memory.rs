//! Memory budgets: what a job will need, estimated before it allocates its grids, and checked
//! against a limit, so a grid too large for the machine is refused with one clear line rather
//! than ending in an allocation failure or the kernel's out-of-memory killer.
//!
//! Every job of [`crate::pipeline`] takes a [`MemoryLimit`]: by default what the machine can
//! give ([`available`]), the kernel's estimate of the memory available to new work
//! (`MemAvailable` in `/proc/meminfo`), and no more than this process's address-space limit
//! (`ulimit -v`) leaves. The estimates are upper bounds of the peak resident memory of the
//! real jobs (a test measures them on real meshes; docs/robustness.md has the table): so many bytes per voxel of each grid the
//! work keeps, per triangle of the mesh, per pixel of a picture, per constraint of a solve,
//! plus a fixed allowance for the program itself.
//!
//! ```
//! use implicitize::memory::{self, Estimate};
//!
//! assert_eq!(memory::parse_size("512M").unwrap(), 512 << 20);
//! let need = Estimate::volume([100, 100, 100], 1000);
//! assert!(need.bytes > 10_000_000);
//! let refusal = need.check(1 << 20, || None).unwrap_err().to_string();
//! assert!(refusal.contains("exceeds the memory limit of 1.0 MB"));
//! ```

use crate::error::{Error, Result};
use crate::grid::Grid;

/// The program itself, its thread stacks and the small tables of any command.
const BASE: u64 = 64 << 20;
/// Bytes per triangle of an input mesh while it is read and voxelized: the file's bytes, the
/// mesh, the re-orientation's edge table and neighbours, and the winding-number tree
/// (measured: 396 for `voxelize` of an open bumpy sphere of 1,965,031 triangles at 64).
const PER_TRIANGLE: u64 = 450;
/// Bytes per voxel of `voxelize` and `sdf`: densities, the centres' states, inside flags, the
/// squared distances and the output (measured: 7.9 on the bunny from 256 to 512).
const VOLUME_PER_VOXEL: u64 = 10;
/// Bytes per voxel of a fit on the full grid: the goal's densities, signed distance and radii,
/// the current surface's values, signed distance and flags, and the voxelization's (measured:
/// 18 on the bunny from 128 to 256).
const FIT_PER_VOXEL: u64 = 28;
/// Bytes per voxel of the goal's grid of a fit with detail levels, whose iterations run on
/// coarser grids: at its peak the measure on that grid holds the goal's signed distance, the
/// model's values and their distance transform (f32 each) and the inside flags; the goal's
/// densities (freed after level 0) with its distance transform hold as much at the start
/// (measured: 13.2 on the bunny at 512 beside its points, 9.8 while making the goal at 1024).
const LEVELS_PER_VOXEL: u64 = 14;

/// Bytes per goal surface point a fit with detail levels holds beyond the fit's grids: a point
/// on the mesh (kept by the goal) and its copy, the point, its residual and error and their
/// copies as candidates, at worst a centre of the finest level with its sparse row (about
/// pi / spacing^2 neighbours of 12 bytes), its support index entries (at most 27 of 4 bytes) and
/// solve vectors, and the band voxels beside it (index and value, 8 bytes each, at most 2 x 16
/// of them, a band being at most `first_radius` voxels of level 0 wide).
const LEVELS_PER_POINT: u64 = 1050;
/// Bytes per matrix entry of a dense solve: the system's matrix and its factorization.
const DENSE_PER_ENTRY: u64 = 16;
/// Bytes per constraint of an iterative solve: the overlapping local blocks' factorizations
/// (each leaf of 512 centres factored with as many neighbours: 8 MB a leaf), the Krylov
/// directions and the treecode's tables.
const ITERATIVE_PER_CONSTRAINT: u64 = 24 << 10;
/// An iterative solve's coarse problem (at most 3,000 centres, factored) and its fixed tables.
const ITERATIVE_BASE: u64 = 160 << 20;
/// Bytes per voxel of polygonizing a field evaluated at every voxel (`dense`): the f64
/// values, the inside bits and the vertices of the surface (measured on the triceratops from
/// 128 to 512: 15 a voxel beyond the fixed part).
const DENSE_PER_VOXEL: u64 = 20;
/// Bytes per voxel of polygonizing a field by following its surface: the visited flags and
/// the vertices and triangles along the surface (measured: 9 a voxel from 256 to 512).
const FOLLOW_PER_VOXEL: u64 = 12;
/// What polygonizing holds whatever the grid: the points of a chunk of a million voxels and
/// their values, and the evaluation's tables.
const POLYGONIZE_BASE: u64 = 96 << 20;
/// Triangles of a fitted model's polygonized surface per voxel face (the square of the voxel
/// size) of its mesh's area: marching tetrahedra cut each cube the surface crosses in about six
/// pieces (measured: 8.6 to 9.2 for the default fits of the bunny, horse and triceratops, 9.2
/// for the bunny at 1024).
const MODEL_TRIANGLES_PER_AREA: f64 = 10.0;
/// Bytes per triangle of a fitted model's polygonized surface while the report measures the mesh
/// against it: the surface (half a vertex and one triangle, 24) and the distance query built
/// over it ([`crate::mesh_query::BYTES_PER_TRIANGLE`]). Polygonizing it holds less
/// (measured: 130 a triangle for the bunny's model of 22.8 million triangles at 1024, its values,
/// visited cubes and edge tables included).
const MODEL_SURFACE_PER_TRIANGLE: u64 = 24 + crate::mesh_query::BYTES_PER_TRIANGLE as u64;
/// Bytes per triangle of a distance query, beyond reading the mesh: the hierarchy while it is
/// built ([`crate::mesh_query::BYTES_PER_TRIANGLE`], 222), for the sign the lines' grids
/// across the three axes (a copy of the re-oriented corners, 72, and for each axis at most 8
/// entries a triangle and about one cell, 40: 192 for the three) and the winding number's tree
/// where the lines disagree (its nodes and reordered corners, about 300). Measured with
/// [`PER_TRIANGLE`]: 417 a triangle all told where the rays settle every point (`implicitize
/// distance` of one point, signed, on a bumpy sphere of 599,850 triangles: 250 MB at the peak;
/// 174 MB unsigned).
const DISTANCE_PER_TRIANGLE: u64 = 900;
/// Bytes per query point of a distance query: the points as read and as vectors, each one's
/// closest point, triangle and barycentrics, its distance and side, and the closest points as
/// written (measured: 140, `implicitize distance --closest` of 1,000,000 points on the
/// triceratops, 167 MB at the peak against 27 MB for one point).
const DISTANCE_PER_POINT: u64 = 192;
/// Bytes per sample of [`crate::pipeline::sample`]: the point and its kind, its distance and
/// side, its signed distance, its DeepSDF row and the arrays of the `.npz` in memory.
const SAMPLE_PER_POINT: u64 = 160;
/// Bytes per pixel of a picture: the colours, depth, normals and positions of the rays.
const PER_PIXEL: u64 = 64;

/// Memory a piece of work will need, and what it is, for the message that refuses it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Estimate {
    /// The estimated peak, in bytes.
    pub bytes: u64,
    /// What needs it, for example `"a grid of 4096 x 1938 x 1876 voxels"`.
    pub what: String,
}

impl Estimate {
    /// `voxelize` or `sdf` of a mesh of `triangles` triangles on a grid of `dims` voxels.
    pub fn volume(dims: [usize; 3], triangles: usize) -> Estimate {
        Estimate::grid(dims, VOLUME_PER_VOXEL, triangles)
    }

    /// `sdf --exact` of a mesh of `triangles` triangles on a grid of `dims` voxels: the
    /// volume's grids (the exact values replace the densities in place; a band's flags take
    /// two bytes a voxel while it is found) and the distance query's hierarchy
    /// (222 bytes a triangle).
    pub fn exact_volume(dims: [usize; 3], triangles: usize) -> Estimate {
        let grid = Estimate::grid(dims, VOLUME_PER_VOXEL, triangles);
        let query = crate::mesh_query::BYTES_PER_TRIANGLE as u64;
        Estimate {
            bytes: grid.bytes.saturating_add(query.saturating_mul(triangles as u64)),
            ..grid
        }
    }

    /// A fit of a mesh of `triangles` triangles (0 for a picture) on a grid of `dims` voxels,
    /// with room for a dense solve of the largest size (`DIRECT_MAX`
    /// constraints); [`Estimate::fit_solving`] budgets larger ones as the fit grows.
    pub fn fit(dims: [usize; 3], triangles: usize) -> Estimate {
        Estimate::fit_solving(dims, triangles, crate::rbf::DIRECT_MAX)
    }

    /// [`Estimate::fit`] with room for a solve of `constraints` constraints (3D): dense up to
    /// `DIRECT_MAX`, iterative beyond.
    pub fn fit_solving(dims: [usize; 3], triangles: usize, constraints: usize) -> Estimate {
        let grid = Estimate::grid(dims, FIT_PER_VOXEL, triangles);
        Estimate { bytes: grid.bytes.saturating_add(solve_bytes(constraints)), ..grid }
    }

    /// What a shell fit (`shell`) adds to [`Estimate::fit`] on a grid of `dims` voxels, of a
    /// mesh of `triangles` triangles: the exact distances' band flags (two bytes a voxel), and
    /// the thickened surface the report measures the model against, polygonized
    /// (`FOLLOW_PER_VOXEL` a voxel) with its distance hierarchy (taken as the mesh's: the
    /// thickened surface of a thin wall has about as many triangles as its two faces).
    pub fn shell(dims: [usize; 3], triangles: usize) -> Estimate {
        let grid = Estimate::grid(dims, 2 + FOLLOW_PER_VOXEL, 0);
        let query = crate::mesh_query::BYTES_PER_TRIANGLE as u64;
        Estimate {
            bytes: grid.bytes.saturating_add(query.saturating_mul(triangles as u64)),
            ..grid
        }
    }

    /// Polygonizing a field on a grid of `dims` voxels, evaluating every voxel (`dense`) or
    /// following the surface.
    pub fn polygonize(dims: [usize; 3], dense: bool) -> Estimate {
        let per_voxel = if dense { DENSE_PER_VOXEL } else { FOLLOW_PER_VOXEL };
        let grid = Estimate::grid(dims, per_voxel, 0);
        Estimate { bytes: grid.bytes.saturating_add(POLYGONIZE_BASE), ..grid }
    }

    /// Distances from `points` points to a mesh of `triangles` triangles
    /// ([`crate::pipeline::distance`]), `signed` or not: unsigned distances need the hierarchy
    /// alone (222 bytes a triangle), not the sign's lines and
    /// winding number (measured: 228 bytes a triangle all told, reading the mesh included, for
    /// `implicitize distance --unsigned` of 10 points to a polygonized bunny of 22.8 million
    /// triangles, 5.2 GB at the peak).
    pub fn distance(triangles: usize, points: usize, signed: bool) -> Estimate {
        let query = if signed {
            DISTANCE_PER_TRIANGLE
        } else {
            crate::mesh_query::BYTES_PER_TRIANGLE as u64
        };
        let per_triangle = PER_TRIANGLE + query;
        Estimate {
            bytes: BASE
                .saturating_add((triangles as u64).saturating_mul(per_triangle))
                .saturating_add((points as u64).saturating_mul(DISTANCE_PER_POINT)),
            what: format!("distances from {points} points to {triangles} triangles"),
        }
    }

    /// `points` samples of the signed distance of a mesh of `triangles` triangles, written
    /// as an `.npz` ([`crate::pipeline::sample`]).
    pub fn sample(triangles: usize, points: usize) -> Estimate {
        let per_triangle = PER_TRIANGLE + DISTANCE_PER_TRIANGLE;
        Estimate {
            bytes: BASE
                .saturating_add((triangles as u64).saturating_mul(per_triangle))
                .saturating_add((points as u64).saturating_mul(SAMPLE_PER_POINT)),
            what: format!("{points} samples of a mesh of {triangles} triangles"),
        }
    }

    /// A fit with detail levels of a mesh of `triangles` triangles on a grid of `dims` voxels,
    /// its goal on a grid of `goal_dims` (`dims`, or a coarser grid: see
    /// `crate::fit::detail::goal_grid`), at `points` surface points
    /// (`LEVELS_PER_POINT` a point): level 0's iterations, on a grid of a
    /// quarter of the goal's resolution or less, fit in what the goal's measure holds. The
    /// model's surface, polygonized on `dims` once the goal is freed, is
    /// [`Estimate::measured_surface`].
    pub fn levels(
        goal_dims: [usize; 3],
        dims: [usize; 3],
        triangles: usize,
        points: usize,
    ) -> Estimate {
        let goal = Estimate::grid(goal_dims, LEVELS_PER_VOXEL, triangles);
        let points = (points as u64).saturating_mul(LEVELS_PER_POINT);
        Estimate { bytes: goal.bytes.saturating_add(points), what: Estimate::grid(dims, 0, 0).what }
    }

    /// A fitted model's surface, polygonized on the fit's grid and measured against its mesh
    /// (the report's `mesh_distance`), for a mesh of `area` voxel faces (mesh units squared
    /// over the square of the voxel size): the surface's triangles
    /// (`MODEL_TRIANGLES_PER_AREA` a voxel face) and the distance query over them. It follows
    /// the fit, whose grids are freed first.
    pub fn measured_surface(area: f64) -> Estimate {
        let triangles = (area * MODEL_TRIANGLES_PER_AREA).ceil() as u64;
        Estimate {
            bytes: BASE.saturating_add(triangles.saturating_mul(MODEL_SURFACE_PER_TRIANGLE)),
            what: format!("a polygonized surface of about {triangles} triangles"),
        }
    }

    /// A picture of `width` x `height` pixels.
    pub fn picture(width: usize, height: usize) -> Estimate {
        let pixels = (width as u64).saturating_mul(height as u64);
        Estimate {
            bytes: BASE.saturating_add(pixels.saturating_mul(PER_PIXEL)),
            what: format!("a picture of {width} x {height} pixels"),
        }
    }

    /// Work of `per_voxel` bytes a voxel of a grid of `dims`, on a mesh of `triangles`.
    fn grid(dims: [usize; 3], per_voxel: u64, triangles: usize) -> Estimate {
        let voxels = dims.iter().fold(1u64, |n, &d| n.saturating_mul(d as u64));
        let bytes = BASE
            .saturating_add(voxels.saturating_mul(per_voxel))
            .saturating_add((triangles as u64).saturating_mul(PER_TRIANGLE));
        Estimate {
            bytes,
            what: format!("a grid of {} x {} x {} voxels", dims[0], dims[1], dims[2]),
        }
    }

    /// Two pieces of work done one after the other, named as the first: the larger of the
    /// first, and the second beside half of what the first needed beyond the program. The
    /// allocator keeps part of what the first frees, resident, while the second runs (measured
    /// with mimalloc, against the same runs with its memory returned at once: 154 MB of the
    /// bunny's default fit, estimated at 356 MB; up to 176 MB of the triceratops's fit with
    /// detail levels at 512, estimated at 518 MB).
    pub fn followed_by(self, other: &Estimate) -> Estimate {
        let kept = (self.bytes - BASE.min(self.bytes)) / 2;
        Estimate { bytes: self.bytes.max(other.bytes.saturating_add(kept)), ..self }
    }

    /// The sum of two pieces of work held at once, named as the first.
    pub fn plus(self, other: &Estimate) -> Estimate {
        Estimate { bytes: self.bytes.saturating_add(other.bytes - BASE.min(other.bytes)), ..self }
    }

    /// Checks the estimate against `limit` bytes. When it does not fit, `largest` names the
    /// largest setting that does, as a backquoted setting such as `` "`resolution=1234`" ``
    /// (see [`Error::worded`]), for the message.
    ///
    /// # Errors
    /// [`Error::Memory`]: one line naming what needs the memory, the estimate, the limit and,
    /// when given, the largest setting that fits.
    pub fn check(&self, limit: u64, largest: impl FnOnce() -> Option<String>) -> Result<()> {
        if self.bytes <= limit {
            return Ok(());
        }
        let hint = match largest() {
            Some(setting) => format!("; the largest that fits is {setting}"),
            None => String::new(),
        };
        Err(Error::Memory {
            context: self.what.clone(),
            message: format!(
                "needs about {}, which exceeds the memory limit of {} (set it with \
                 `memory_limit`){hint}",
                show_size(self.bytes),
                show_size(limit)
            ),
        })
    }

    /// [`Estimate::check`] for work on a grid placed at a resolution: when it does not fit,
    /// the message names the largest `resolution` (voxels along the longest axis) whose
    /// estimate, `at_resolution` (`None` where no grid can be placed), fits.
    ///
    /// # Errors
    /// As [`Estimate::check`].
    pub fn check_grid(
        &self,
        limit: u64,
        at_resolution: impl Fn(usize) -> Option<u64>,
    ) -> Result<()> {
        self.check(limit, || {
            largest_fitting(2 * Grid::MARGIN + 2..=Grid::MAX_AXIS, limit, at_resolution)
                .map(|n| format!("`resolution={n}`"))
        })
    }
}

/// The solve of `constraints` constraints, without the program's own allowance.
fn solve_bytes(constraints: usize) -> u64 {
    let n = constraints as u64;
    if constraints <= crate::rbf::DIRECT_MAX {
        DENSE_PER_ENTRY.saturating_mul((n + 4) * (n + 4))
    } else {
        ITERATIVE_BASE.saturating_add(n.saturating_mul(ITERATIVE_PER_CONSTRAINT))
    }
}

/// How much memory a job may use.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum MemoryLimit {
    /// What the machine has available when the job starts ([`available`]).
    #[default]
    Available,
    /// This many bytes.
    Bytes(u64),
}

impl MemoryLimit {
    /// The limit in bytes (no limit where the available memory cannot be read).
    pub fn bytes(self) -> u64 {
        match self {
            MemoryLimit::Available => available().unwrap_or(u64::MAX),
            MemoryLimit::Bytes(bytes) => bytes,
        }
    }

    /// Each one's share when `jobs` jobs run at once under this limit.
    pub fn share(self, jobs: usize) -> MemoryLimit {
        MemoryLimit::Bytes(self.bytes() / jobs.max(1) as u64)
    }
}

/// The largest value of `setting` in `range` whose estimate fits in `limit` bytes, given that
/// estimates grow with the setting, or `None` when even the smallest does not fit.
pub(crate) fn largest_fitting(
    range: std::ops::RangeInclusive<usize>,
    limit: u64,
    estimate: impl Fn(usize) -> Option<u64>,
) -> Option<usize> {
    let fits = |n: usize| estimate(n).is_some_and(|bytes| bytes <= limit);
    let (mut low, mut high) = (*range.start(), *range.end());
    if !fits(low) {
        return None;
    }
    while low < high {
        let middle = low + (high - low).div_ceil(2);
        if fits(middle) { low = middle } else { high = middle - 1 }
    }
    Some(low)
}

/// A size in bytes, KB, MB, GB or TB (powers of 1024), with one decimal.
pub(crate) fn show_size(bytes: u64) -> String {
    let units = ["bytes", "KB", "MB", "GB", "TB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < units.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 { format!("{bytes} bytes") } else { format!("{value:.1} {}", units[unit]) }
}

/// Parses a size such as `1G`, `512M`, `1.5GB`, `800k` or `1000000` (bytes); the units are
/// powers of 1024 and their case does not matter.
///
/// # Errors
/// An error naming the text when it is not a positive size.
pub fn parse_size(text: &str) -> Result<u64> {
    let invalid = || {
        Error::invalid(
            format!("memory size {text:?}"),
            "expected a positive number with an optional unit K, M, G or T, as 512M or 1.5G",
        )
    };
    let lower = text.trim().to_ascii_lowercase();
    let number = lower.strip_suffix('b').unwrap_or(&lower);
    let (digits, shift) = match number.char_indices().last() {
        Some((i, 'k')) => (&number[..i], 10),
        Some((i, 'm')) => (&number[..i], 20),
        Some((i, 'g')) => (&number[..i], 30),
        Some((i, 't')) => (&number[..i], 40),
        _ => (number, 0),
    };
    let value: f64 = digits.trim().parse().map_err(|_| invalid())?;
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(invalid());
    }
    Ok(bytes as u64)
}

/// The memory this process can still get: the machine's available memory (`MemAvailable`)
/// and, under an address-space limit (`ulimit -v`), no more than the limit less the address
/// space already in use. `None` where neither can be read (not Linux).
pub fn available() -> Option<u64> {
    let machine = meminfo_available();
    let address_space = address_space_left();
    match (machine, address_space) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// `MemAvailable` of `/proc/meminfo`, in bytes.
fn meminfo_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kilobytes_field(&text, "MemAvailable:")
}

/// The soft address-space limit of `/proc/self/limits` less the address space in use
/// (`VmSize` of `/proc/self/status`), or `None` when unlimited or unreadable.
fn address_space_left() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    let soft: u64 = line["Max address space".len()..].split_whitespace().next()?.parse().ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let used = kilobytes_field(&status, "VmSize:").unwrap_or(0);
    Some(soft.saturating_sub(used))
}

/// The value of a `NAME:   1234 kB` line, in bytes.
fn kilobytes_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kb: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// Turns transparent huge pages off for this process (Linux; inherited by its children), as
/// both front ends do at start (the command line's `main`, the Python module's import). With
/// them, mimalloc, the front ends' allocator, asks for huge pages over its large regions, and
/// every fresh 2 MiB the kernel hands in is zeroed whole, for allocations that touch a few pages
/// of it: the kernel's zeroing took 10 to 19% of the CPU of a default fit and of `sample`
/// (docs/results.md, "Huge pages"). A kernel that refuses the call leaves the default.
pub fn refuse_huge_pages() {
    #[cfg(target_os = "linux")]
    // SAFETY: PR_SET_THP_DISABLE reads only its integer arguments and touches no memory of ours.
    unsafe {
        libc::prctl(
            libc::PR_SET_THP_DISABLE,
            1 as libc::c_ulong,
            0 as libc::c_ulong,
            0 as libc::c_ulong,
            0 as libc::c_ulong,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_powers_of_1024() {
        assert_eq!(parse_size("1G").unwrap(), 1 << 30);
        assert_eq!(parse_size("512m").unwrap(), 512 << 20);
        assert_eq!(parse_size("1.5GB").unwrap(), 3 << 29);
        assert_eq!(parse_size("800K").unwrap(), 800 << 10);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        for bad in ["", "G", "-1G", "0", "1X", "nan", "inf", "1e30T"] {
            let message = parse_size(bad).unwrap_err().to_string();
            assert!(message.contains("memory size"), "{bad}: {message}");
        }
    }

    #[test]
    fn sizes_show_with_their_unit() {
        assert_eq!(show_size(512), "512 bytes");
        assert_eq!(show_size(1 << 30), "1.0 GB");
        assert_eq!(show_size(3 << 29), "1.5 GB");
    }

    #[test]
    fn the_largest_fitting_setting_is_found() {
        let estimate = |n: usize| Some((n as u64).pow(3));
        assert_eq!(largest_fitting(8..=4096, 1000, estimate), Some(10));
        assert_eq!(largest_fitting(8..=4096, 999, estimate), Some(9));
        assert_eq!(largest_fitting(8..=4096, 100, estimate), None);
        assert_eq!(largest_fitting(8..=4096, u64::MAX, estimate), Some(4096));
    }

    #[test]
    fn a_refusal_names_the_estimate_the_limit_and_the_largest_setting() {
        let need = Estimate::volume([4096, 2000, 2000], 10);
        let message = need.check(1 << 30, || Some("`resolution=400`".into())).unwrap_err();
        let message = message.worded(crate::error::FrontEnd::Cli);
        assert!(message.starts_with("a grid of 4096 x 2000 x 2000 voxels: needs about "));
        assert!(message.contains("memory limit of 1.0 GB (set it with --memory-limit)"));
        assert!(message.ends_with("the largest that fits is --resolution 400"), "{message}");
        assert!(need.check(u64::MAX, || None).is_ok());
    }

    #[test]
    fn this_machine_has_some_memory_available() {
        let bytes = available().expect("Linux reports its available memory");
        assert!(bytes > 1 << 20);
        assert_eq!(kilobytes_field("MemAvailable:   2048 kB\n", "MemAvailable:"), Some(2 << 20));
    }
}
