//! The signed distance function of a voxelized shape (paper section 4.2), its boundary voxels
//! ∂f, sub-voxel surface points (5.3) and its gradient (5.1).
//!
//! Where the paper used Danielsson's approximate method, [`signed_distance`] is the exact
//! Euclidean distance transform of Felzenszwalb and Huttenlocher (lower envelopes of parabolas,
//! one pass per axis), linear in the number of voxels and parallel over lines. It equals
//! SciPy's `distance_transform_edt` with the convention
//! `sd = where(inside, edt(inside) - 0.5, -(edt(~inside) - 0.5))`: positive inside, negative
//! outside, in voxels, so voxels on either side of the surface are ±1/2.
//! `signed_distance_within` is the same transform exact only within a band around the
//! surface (what the fit reads of its current surface's), which skips most of the work on
//! large grids.
//!
//! Positions are continuous voxel coordinates of the volume's grid (voxel centres at whole
//! numbers), f64; the volumes themselves are f32, whose 24-bit mantissa holds every squared
//! distance exactly on grids up to 2365 voxels along each axis.

use rayon::prelude::*;

use crate::geometry::DVec3;
use crate::grid::Volume;

/// Inside/outside from densities: inside where the density exceeds 1/2.
pub fn inside(density: &Volume<f32>) -> Volume<bool> {
    Volume { grid: density.grid, data: density.data.par_iter().map(|&d| d > 0.5).collect() }
}

/// The exact signed Euclidean distance transform of `inside`, in voxels, inside positive:
/// an inside voxel gets its distance to the nearest outside voxel minus 1/2, an outside voxel
/// minus (its distance to the nearest inside voxel minus 1/2).
///
/// A volume with no voxel of the other state gets +∞ (all inside) or -∞ (all outside).
pub fn signed_distance(inside: &Volume<bool>) -> Volume<f32> {
    transform(inside, f64::INFINITY)
}

/// [`signed_distance`] within a band around the surface: every voxel less than `band` voxels
/// from the nearest voxel of the other state gets its exact value (below `band - 1/2` in size);
/// every other voxel gets `band - 1/2` with its sign, a lower bound on its size. `band` is
/// taken as at least 1.
///
/// The transform is the same, with the parabolas of squared distances of at least `band^2`
/// left out of the second and third passes: none of them can be the nearest for a voxel
/// nearer than `band`, and where the band is thin beside the grid most lines have few of the
/// others.
pub(crate) fn signed_distance_within(inside: &Volume<bool>, band: f32) -> Volume<f32> {
    transform(inside, f64::from(band.max(1.0)))
}

/// The transform of [`signed_distance`], exact for voxels nearer than `band` to the other
/// state (all of them when `band` is infinite).
fn transform(inside: &Volume<bool>, band: f64) -> Volume<f32> {
    let grid = inside.grid;
    let [nx, ny, nz] = grid.dims;
    let states = &inside.data;
    let mut d2 = vec![0.0f32; grid.len()];
    if grid.is_empty() {
        return Volume { grid, data: d2 };
    }
    let cutoff = band * band;
    // Along i first: the 1D distances need only the states, swept slab by slab.
    axis_i_distances(states, &mut d2, nx, ny * nz);
    // Along j: within each i-slab.
    d2.par_chunks_mut(ny * nz).zip(states.par_chunks(ny * nz)).for_each_init(
        || Line::new(ny, cutoff),
        |line, (slab, state)| {
            for k in 0..nz {
                if line.load(|j| (state[j * nz + k], slab[j * nz + k])) {
                    line.solve(|j, d| slab[j * nz + k] = d);
                }
            }
        },
    );
    // Along k: rows are contiguous.
    d2.par_chunks_mut(nz).zip(states.par_chunks(nz)).for_each_init(
        || Line::new(nz, cutoff),
        |line, (row, state)| {
            if line.load(|k| (state[k], row[k])) {
                line.solve(|k, d| row[k] = d);
            }
        },
    );
    d2.par_iter_mut().zip(states.par_iter()).for_each(|(d, &inside)| {
        // In f64 then rounded once, as SciPy's float64 result cast to float32. (With an
        // infinite band, an infinite squared distance gives an infinite result either way.)
        let squared = f64::from(*d);
        let r = if squared >= cutoff { band } else { squared.sqrt() } - 0.5;
        *d = if inside { r as f32 } else { -r as f32 };
    });
    Volume { grid, data: d2 }
}

/// Squared distances along i (the outermost axis, `plane` voxels apart) from each voxel to the
/// nearest voxel of the other state on its line: a forward and a backward [`sweep`].
fn axis_i_distances(states: &[bool], d2: &mut [f32], nx: usize, plane: usize) {
    d2.par_iter_mut().for_each(|d| *d = f32::INFINITY);
    sweep(states, d2, nx, plane, true);
    sweep(states, d2, nx, plane, false);
}

/// One sweep of [`axis_i_distances`], slab by slab, forward or backward: for every line at once
/// it keeps the last voxel seen whose state differs from the next one's, and lowers each
/// voxel's squared distance to it. Every access is to contiguous memory, and each slab is split
/// between the threads.
fn sweep(states: &[bool], d2: &mut [f32], nx: usize, plane: usize, forward: bool) {
    const NONE: u32 = u32::MAX;
    let chunk = plane.div_ceil(rayon::current_num_threads() * 4).max(1024);
    let mut seen = vec![NONE; plane];
    let slabs: Vec<usize> = if forward { (0..nx).collect() } else { (0..nx).rev().collect() };
    for i in slabs {
        let neighbour = if forward { i.checked_sub(1) } else { (i + 1 < nx).then_some(i + 1) };
        let slab = &states[i * plane..(i + 1) * plane];
        // The slab swept just before this one, and its index.
        let before = neighbour.map(|b| (b as u32, &states[b * plane..(b + 1) * plane]));
        let out = &mut d2[i * plane..(i + 1) * plane];
        out.par_chunks_mut(chunk).zip(seen.par_chunks_mut(chunk)).enumerate().for_each(
            |(c, (out, seen))| {
                let start = c * chunk;
                for (n, (d, last)) in out.iter_mut().zip(seen.iter_mut()).enumerate() {
                    if let Some((b, other)) = before
                        && other[start + n] != slab[start + n]
                    {
                        *last = b;
                    }
                    if *last != NONE {
                        *d = d.min((i.abs_diff(*last as usize).pow(2)) as f32);
                    }
                }
            },
        );
    }
}

/// Scratch space for the 1D lower envelope of parabolas along one line (Felzenszwalb and
/// Huttenlocher), run once for the inside voxels and once for the outside ones.
///
/// Every height is a whole number (squared distances between voxels), so the envelope's
/// breakpoints are kept as fractions and compared by cross-multiplication, exactly and without
/// a division (their products stay far below 2^53, where f64 holds whole numbers exactly).
struct Line {
    /// Squared distances from here on are left out of the envelope (see [`transform`]).
    cutoff: f64,
    f: Vec<f64>,
    state: Vec<bool>,
    /// The envelope's parabolas: their voxels, their heights `f(p) + p^2`, and where each
    /// begins, `z[k] = z_num[k] / z_den[k]` (`z_den > 0`), from the second on.
    v: Vec<usize>,
    h: Vec<f64>,
    z_num: Vec<f64>,
    z_den: Vec<f64>,
}

impl Line {
    fn new(n: usize, cutoff: f64) -> Line {
        Line {
            cutoff,
            f: vec![0.0; n],
            state: vec![false; n],
            v: vec![0; n],
            h: vec![0.0; n],
            z_num: vec![0.0; n],
            z_den: vec![1.0; n],
        }
    }

    /// Reads each voxel's state and squared distance so far with `get`, and says whether the
    /// line needs solving: not when all its voxels share a state and are at least the cutoff
    /// away already, so that no voxel of it can come nearer.
    fn load(&mut self, get: impl Fn(usize) -> (bool, f32)) -> bool {
        let mut needed = false;
        for q in 0..self.f.len() {
            let (s, d) = get(q);
            self.state[q] = s;
            self.f[q] = f64::from(d);
            needed |= s != self.state[0] || self.f[q] < self.cutoff;
        }
        needed
    }

    /// Writes with `set` each voxel's squared distance to the nearest voxel of the other
    /// state, over the line and the distances loaded.
    fn solve(&mut self, mut set: impl FnMut(usize, f32)) {
        for side in [true, false] {
            if !self.state.contains(&side) {
                continue;
            }
            // For voxels of `side`, voxels of the other state are features at distance 0.
            let parabolas = self.envelope(side);
            let mut k = 0usize;
            for q in 0..self.f.len() {
                if self.state[q] != side {
                    continue;
                }
                if parabolas == 0 {
                    set(q, f32::INFINITY);
                    continue;
                }
                // Parabola k + 1 takes over once q is past where it begins.
                while k + 1 < parabolas && self.z_num[k + 1] < q as f64 * self.z_den[k + 1] {
                    k += 1;
                }
                let dq = q as f64 - self.v[k] as f64;
                set(q, (dq * dq + self.h[k] - (self.v[k] * self.v[k]) as f64) as f32);
            }
        }
    }

    /// Builds the lower envelope of the parabolas `(x - p)^2 + f(p)` over the voxels `p` of the
    /// line with `f(p)` taken as 0 for voxels not of `side` (only those beside a voxel of `side`
    /// can be lowest at a voxel of `side`), and returns how many it has.
    fn envelope(&mut self, side: bool) -> usize {
        let n = self.f.len();
        let mut count = 0usize;
        for q in 0..n {
            let fq = if self.state[q] == side {
                self.f[q]
            } else if (q > 0 && self.state[q - 1] == side)
                || (q + 1 < n && self.state[q + 1] == side)
            {
                0.0
            } else {
                // Inside a run of the other state: the run's ends are nearer every voxel of
                // `side` on the line.
                continue;
            };
            if fq >= self.cutoff {
                continue;
            }
            let hq = fq + (q * q) as f64;
            // Drop the parabolas the new one lies below from where they begin: it meets
            // parabola k at s = (hq - h[k]) / (2 (q - v[k])).
            while count > 1 {
                let k = count - 1;
                let (num, den) = (hq - self.h[k], 2.0 * (q - self.v[k]) as f64);
                if num * self.z_den[k] > self.z_num[k] * den {
                    break;
                }
                count -= 1;
            }
            if count > 0 {
                let k = count - 1;
                (self.z_num[count], self.z_den[count]) =
                    (hq - self.h[k], 2.0 * (q - self.v[k]) as f64);
            }
            (self.v[count], self.h[count]) = (q, hq);
            count += 1;
        }
        count
    }
}

/// The boundary voxels ∂f: inside voxels with a 6-neighbour outside, i.e. where `sd == 1/2`,
/// sorted by index.
pub(crate) fn boundary_voxels(sd: &Volume<f32>) -> Vec<[usize; 3]> {
    let grid = sd.grid;
    sd.data
        .par_iter()
        .enumerate()
        .filter(|&(_, &d)| d == 0.5)
        .map(|(index, _)| grid.voxel(index))
        .collect()
}

/// The sub-voxel point near `voxel` where the density crosses 1/2 (paper 5.3), in continuous
/// voxel coordinates.
///
/// Along each axis where a 6-neighbour lies on the other side of 1/2, the crossing is placed
/// between the two voxels as `crossing` explains; the point is the mean of these crossings. With no
/// such neighbour, one Newton step along the density's central-difference gradient, at most
/// one voxel long; with a flat density, the voxel's centre.
///
/// # Panics
/// If `voxel` lies outside the volume's grid.
pub(crate) fn surface_point(density: &Volume<f32>, voxel: [usize; 3]) -> DVec3 {
    let grid = density.grid;
    let centre = DVec3::from_array(voxel.map(|x| x as f64));
    let d0 = f64::from(*density.get(voxel));
    let mut sum = DVec3::ZERO;
    let mut count = 0;
    let mut gradient = DVec3::ZERO;
    for axis in 0..3 {
        let neighbour = |step: isize| -> Option<f64> {
            let x = voxel[axis] as isize + step;
            (0..grid.dims[axis] as isize).contains(&x).then(|| {
                let mut n = voxel;
                n[axis] = x as usize;
                f64::from(*density.get(n))
            })
        };
        let (below, above) = (neighbour(-1), neighbour(1));
        for (step, d) in [(-1.0, below), (1.0, above)] {
            if let Some(d) = d
                && (d > 0.5) != (d0 > 0.5)
            {
                let mut p = centre;
                p[axis] += step * crossing(d0, d);
                sum += p;
                count += 1;
            }
        }
        gradient[axis] = match (below, above) {
            (Some(b), Some(a)) => 0.5 * (a - b),
            (Some(b), None) => d0 - b,
            (None, Some(a)) => a - d0,
            (None, None) => 0.0,
        };
    }
    if count > 0 {
        return sum / count as f64;
    }
    let g2 = gradient.length_squared();
    if g2 == 0.0 {
        return centre;
    }
    let step = (0.5 - d0) * gradient / g2;
    centre + step.clamp_length_max(1.0)
}

/// Where between two adjacent voxels with densities `a` and `b` on either side of 1/2 the
/// density crosses 1/2, as a fraction of the way from the first to the second.
///
/// Two fractional densities are interpolated linearly. A density clamped at 0 or 1 says only
/// that the voxel is entirely on one side, so the crossing is then read from the fractional
/// one as a box-filtered plane gives it (density changing by 1 per voxel across the surface):
/// exact for surfaces perpendicular to the axis.
fn crossing(a: f64, b: f64) -> f64 {
    let fractional = |d: f64| d > 0.0 && d < 1.0;
    let t = match (fractional(a), fractional(b)) {
        (true, true) => (a - 0.5) / (a - b),
        (true, false) => (a - 0.5).abs(),
        (false, true) => 1.0 - (b - 0.5).abs(),
        (false, false) => 0.5,
    };
    t.clamp(0.0, 1.0)
}

/// The value of `sd` at `p` by trilinear interpolation (bilinear on 2D grids), `p` clamped
/// to the grid. Inside positive.
pub fn sample(sd: &Volume<f32>, p: DVec3) -> f32 {
    let (corners, w) = cell(sd, p);
    let mut value = 0.0;
    let factors = w.map(|w| [1.0 - w, w]);
    for (c, &index) in corners.iter().enumerate() {
        let weight = factors[0][c & 1] * factors[1][c >> 1 & 1] * factors[2][c >> 2 & 1];
        if weight != 0.0 {
            value += weight * f64::from(sd.data[index]);
        }
    }
    value as f32
}

/// The gradient of `sd` at `p`: central differences of the trilinear field [`sample`] over
/// one voxel (half a voxel each side, clamped to the grid), in value per voxel. It points
/// inward (uphill); z is 0 on 2D grids.
pub(crate) fn gradient(sd: &Volume<f32>, p: DVec3) -> DVec3 {
    let mut g = DVec3::ZERO;
    for axis in 0..3 {
        let n = sd.grid.dims[axis];
        if n < 2 {
            continue;
        }
        let max = (n - 1) as f64;
        let x = p[axis].clamp(0.0, max);
        let (lo, hi) = ((x - 0.5).max(0.0), (x + 0.5).min(max));
        let (mut a, mut b) = (p, p);
        a[axis] = lo;
        b[axis] = hi;
        g[axis] = f64::from(sample(sd, b) - sample(sd, a)) / (hi - lo);
    }
    g
}

/// The 8 voxel indices of the cell holding `p` (clamped) and the fractional position in it.
fn cell(volume: &Volume<f32>, p: DVec3) -> ([usize; 8], [f64; 3]) {
    let grid = volume.grid;
    let mut lo = [0usize; 3];
    let mut hi = [0usize; 3];
    let mut w = [0.0; 3];
    for axis in 0..3 {
        let max = grid.dims[axis].saturating_sub(1);
        let x = if p[axis].is_nan() { 0.0 } else { p[axis].clamp(0.0, max as f64) };
        // x >= 0, so truncation is its floor (and needs no libm call on the baseline ISA).
        lo[axis] = (x as usize).min(max);
        hi[axis] = (lo[axis] + 1).min(max);
        w[axis] = x - lo[axis] as f64;
    }
    let corners = std::array::from_fn(|c| {
        let pick = |a: usize| if c >> a & 1 == 1 { hi[a] } else { lo[a] };
        grid.index([pick(0), pick(1), pick(2)])
    });
    (corners, w)
}
