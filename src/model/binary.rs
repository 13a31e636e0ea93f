//! The binary model file: the same model as the JSON one, numbers on a lattice stored as small
//! integers and entropy-coded, everything else as little-endian f64.
//!
//! ```text
//! file    = "IMPZ" version:u8 stream stream stream      (version 2)
//! stream  = length:varint zstd-frame (stating its size)   meta, points, integers
//! meta    = bounds:6 f64, grid?, shape
//! grid?   = 0 | 1 dims:3 varint origin:3 f64 voxel_size:f64
//! shape   = 0 rbf | 1 levels | 2 csg
//! rbf     = kernel:u8 dim:u8 n:varint translate:dim f64 scale:f64 polynomial:dim+1 f64
//!           residual:f64 ( 0 centres:n*dim f64 values:n f64 weights:n f64   (raw)
//!                        | 1 lattice points values:n int weights:n int )    (3D on a lattice)
//! levels  = rbf count:varint ( radius:f64 n:varint ( 0 centres:n*3 f64 weights:n f64
//!                                                  | 1 lattice points weights:n int ) )*
//! csg     = op:u8 blend:f64 count:varint ( scale:f64 bounds:6 f64 shape )*
//! lattice = origin:3 f64 cell:f64 weight_step:f64 value_step:f64
//! points  = offset:3 int depth:u8, and in the points stream the octree's occupancy
//!           (octree.rs): the centres in Morton order
//! int     = zigzag varint, in the integers stream
//! ```
//!
//! The points stream holds the occupancy of every octree in the file, in order, arithmetic-coded
//! (occupancy.rs); version 1 held the occupancy bytes as they are, and is still read. The three
//! streams are compressed apart (zstd at its strongest level) so that each holds numbers of one
//! kind. A function whose numbers lie on its lattice is written as integers
//! (checked number by number: one off the lattice writes the raw form), so reading it gives
//! the same f64s and it evaluates bit for bit as the model written. The fit report is not
//! stored: the file holds what evaluation needs.

use std::path::Path;

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3, MORTON_BITS};
use crate::grid::Grid;
use crate::rbf::MultiScale;
use crate::rbf::{self, Constraint, DetailLevel, Implicit, Kernel, Lattice, Normalization};
use crate::shape::Shape;
use crate::shape::csg::{Child, Composite, Operation};

use super::{occupancy, octree};

/// The first bytes of every binary model file.
pub const MAGIC: &[u8; 4] = b"IMPZ";

/// The version of the binary format this build writes; it reads this one and every one before.
pub const VERSION: u8 = 2;

/// zstd's strongest level short of its "ultra" ones, whose windows the files never need.
const LEVEL: i32 = 19;

/// No stream of a file decompresses to more than this many bytes per byte of the file, plus
/// [`SLACK`]: a file that claims more is refused before its bytes are allocated.
const MAX_RATIO: usize = 64;
const SLACK: usize = 1 << 20;

/// The nesting of CSG trees a file may hold.
const MAX_DEPTH: usize = 64;

/// The model's bytes: shape, bounds and grid.
pub(crate) fn encode(shape: &Shape, bounds: &Aabb, grid: Option<&Grid>) -> Vec<u8> {
    let mut w = Writer::default();
    w.bounds(bounds);
    match grid {
        None => w.u8(0),
        Some(g) => {
            w.u8(1);
            g.dims.iter().for_each(|&d| w.varint(d as u64));
            g.origin.iter().for_each(|&o| w.f64(o));
            w.f64(g.voxel_size);
        }
    }
    w.shape(shape);
    let mut file = MAGIC.to_vec();
    // A file without octrees is the same in both versions: the older one, which more builds read.
    file.push(if w.occupancy.is_empty() { 1 } else { VERSION });
    let points = w.occupancy.finish();
    for stream in [&w.meta, &points, &w.integers] {
        let packed = zstd::bulk::compress(stream, LEVEL).expect("compressing to memory");
        push_varint(&mut file, packed.len() as u64);
        file.extend_from_slice(&packed);
    }
    file
}

/// The shape, bounds and grid of a binary model file's `bytes`; `path` names it in errors.
pub(crate) fn decode(bytes: &[u8], path: &Path) -> Result<(Shape, Aabb, Option<Grid>)> {
    let bad = |message: String| Error::parse(path, None, message);
    let body = bytes.strip_prefix(MAGIC).ok_or_else(|| bad("not a binary model".into()))?;
    let (&version, mut rest) = body.split_first().ok_or_else(|| bad("no version".into()))?;
    if !(1..=VERSION).contains(&version) {
        return Err(bad(format!(
            "binary model format version {version} is not supported; this build reads versions \
             1 to {VERSION}"
        )));
    }
    let limit = bytes.len().saturating_mul(MAX_RATIO).saturating_add(SLACK);
    let mut streams = Vec::new();
    for name in ["meta", "points", "integers"] {
        let length = read_varint(&mut rest).map_err(|e| bad(format!("the {name} stream: {e}")))?;
        let (packed, after) =
            usize::try_from(length)
                .ok()
                .and_then(|n| rest.split_at_checked(n))
                .ok_or_else(|| bad(format!("the {name} stream is cut short (truncated file?)")))?;
        rest = after;
        let size =
            zstd::zstd_safe::get_frame_content_size(packed).ok().flatten().ok_or_else(|| {
                bad(format!("the {name} stream is not a zstd frame that states its size"))
            })?;
        if size > limit as u64 {
            return Err(bad(format!("the {name} stream claims {size} bytes, too many")));
        }
        let stream = zstd::bulk::decompress(packed, size as usize)
            .map_err(|e| bad(format!("the {name} stream does not decompress: {e}")))?;
        streams.push(stream);
    }
    if !rest.is_empty() {
        return Err(bad(format!("{} bytes after the last stream", rest.len())));
    }
    let context = path.display().to_string();
    let occupancy = match version {
        1 => Occupancy::Bytes(&streams[1]),
        _ => Occupancy::Coded(occupancy::Decoder::new(&streams[1]).map_err(bad)?),
    };
    let mut r = Reader { meta: &streams[0], occupancy, integers: &streams[2], context: &context };
    let bounds = r.bounds()?;
    let grid = match r.u8()? {
        0 => None,
        1 => Some(r.grid()?),
        flag => return Err(r.error(format!("grid flag {flag}"))),
    };
    let shape = r.shape(&context, 0)?;
    if !(r.meta.is_empty() && r.occupancy.is_done() && r.integers.is_empty()) {
        return Err(r.error("bytes left over after the shape".into()));
    }
    Ok((shape, bounds, grid))
}

fn push_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn read_varint(bytes: &mut &[u8]) -> std::result::Result<u64, String> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let (&b, rest) = bytes.split_first().ok_or("ends inside a number")?;
        *bytes = rest;
        v |= u64::from(b & 0x7f) << shift;
        if b < 0x80 {
            return Ok(v);
        }
    }
    Err("a number longer than 64 bits".into())
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn unzigzag(v: u64) -> i64 {
    (v >> 1) as i64 ^ -((v & 1) as i64)
}

/// The three streams being written.
#[derive(Default)]
struct Writer {
    meta: Vec<u8>,
    occupancy: occupancy::Encoder,
    integers: Vec<u8>,
}

impl Writer {
    fn u8(&mut self, v: u8) {
        self.meta.push(v);
    }

    fn varint(&mut self, v: u64) {
        push_varint(&mut self.meta, v);
    }

    fn f64(&mut self, v: f64) {
        self.meta.extend_from_slice(&v.to_le_bytes());
    }

    fn int(&mut self, v: i64) {
        push_varint(&mut self.integers, zigzag(v));
    }

    fn bounds(&mut self, b: &Aabb) {
        b.min.to_array().into_iter().chain(b.max.to_array()).for_each(|v| self.f64(v));
    }

    fn shape(&mut self, shape: &Shape) {
        match shape {
            Shape::Rbf(implicit) => {
                self.u8(0);
                self.rbf(implicit);
            }
            Shape::Levels(levels) => {
                self.u8(1);
                self.rbf(levels.base());
                self.varint(levels.levels().len() as u64);
                levels.levels().iter().for_each(|l| self.level(l));
            }
            Shape::Csg(composite) => {
                self.u8(2);
                self.u8(operation_code(composite.operation()));
                self.f64(composite.blend());
                self.varint(composite.children().len() as u64);
                for child in composite.children() {
                    self.f64(child.scale());
                    self.bounds(&child.bounds());
                    self.shape(child.shape());
                }
            }
        }
    }

    fn rbf(&mut self, f: &Implicit) {
        self.u8(kernel_code(f.kernel()));
        self.u8(f.dim() as u8);
        self.varint(f.len() as u64);
        let normalization = f.normalization();
        normalization.translate.iter().for_each(|&v| self.f64(v));
        self.f64(normalization.scale);
        f.polynomial().iter().for_each(|&v| self.f64(v));
        self.f64(f.residual());
        let constraints = f.constraints();
        let on_lattice = f.lattice().filter(|_| f.dim() == 3).and_then(|lattice| {
            let positions: Vec<DVec3> =
                constraints.iter().map(|c| DVec3::from_slice(c.position())).collect();
            let keys = lattice_keys(lattice, &positions)?;
            // The file lists the centres in the octree's order, which must be the function's.
            let order = rbf::lattice_order(&keys)?;
            if order.iter().enumerate().any(|(i, &j)| i != j) {
                return None;
            }
            let values = multiples(constraints.iter().map(|c| c.value()), lattice.value_step)?;
            let weights = multiples(f.weights().iter().copied(), lattice.weight_step)?;
            Some((lattice, keys, values, weights))
        });
        match on_lattice {
            Some((lattice, keys, values, weights)) => {
                self.u8(1);
                self.lattice(lattice);
                self.point_set(&keys);
                values.into_iter().chain(weights).for_each(|v| self.int(v));
            }
            None => {
                self.u8(0);
                constraints.iter().flat_map(|c| c.position()).for_each(|&v| self.f64(v));
                constraints.iter().for_each(|c| self.f64(c.value()));
                f.weights().iter().for_each(|&v| self.f64(v));
            }
        }
    }

    fn level(&mut self, level: &DetailLevel) {
        self.f64(level.radius());
        self.varint(level.centres().len() as u64);
        let on_lattice = level.lattice().and_then(|lattice| {
            let keys = lattice_keys(lattice, level.centres())?;
            // The file lists the centres in the octree's order; the level orders them itself.
            let order = rbf::lattice_order(&keys)?;
            let weights =
                multiples(order.iter().map(|&i| level.weights()[i]), lattice.weight_step)?;
            let keys: Vec<[i64; 3]> = order.iter().map(|&i| keys[i]).collect();
            Some((lattice, keys, weights))
        });
        match on_lattice {
            Some((lattice, keys, weights)) => {
                self.u8(1);
                self.lattice(lattice);
                self.point_set(&keys);
                weights.into_iter().for_each(|v| self.int(v));
            }
            None => {
                self.u8(0);
                level.centres().iter().flat_map(|c| c.to_array()).for_each(|v| self.f64(v));
                level.weights().iter().for_each(|&v| self.f64(v));
            }
        }
    }

    fn lattice(&mut self, l: &Lattice) {
        l.origin.to_array().into_iter().for_each(|v| self.f64(v));
        for v in [l.cell, l.weight_step, l.value_step] {
            self.f64(v);
        }
    }

    /// `keys`, distinct and in the lattice's Morton order: their offset and depth in the meta
    /// stream, the octree in the points stream.
    fn point_set(&mut self, keys: &[[i64; 3]]) {
        let (lo, hi) = rbf::lattice_extent(keys).unwrap_or(([0; 3], [0; 3]));
        lo.iter().for_each(|&v| self.int(v));
        let span = (0..3).map(|a| (hi[a] - lo[a]) as u64).max().unwrap_or(0);
        let depth = 64 - span.leading_zeros();
        self.u8(depth as u8);
        let offsets: Vec<[u64; 3]> =
            keys.iter().map(|k| [0, 1, 2].map(|a| (k[a] - lo[a]) as u64)).collect();
        self.occupancy.octree(&octree::encode(&offsets, depth));
    }
}

/// The lattice indices of `positions` in their order, None when one is off the lattice, two
/// share a point, or they span too much for the octree.
fn lattice_keys(lattice: &Lattice, positions: &[DVec3]) -> Option<Vec<[i64; 3]>> {
    if !lattice.is_valid() {
        return None;
    }
    let keys: Vec<[i64; 3]> = positions.iter().map(|&p| lattice.index(p)).collect::<Option<_>>()?;
    let order = rbf::lattice_order(&keys)?;
    order.windows(2).all(|w| keys[w[0]] != keys[w[1]]).then_some(keys)
}

/// The integers `k` with `k * step` equal to each value, None when one is not such a multiple.
fn multiples(values: impl Iterator<Item = f64>, step: f64) -> Option<Vec<i64>> {
    values.map(|v| Lattice::multiple(v, step)).collect()
}

fn kernel_code(kernel: Kernel) -> u8 {
    match kernel {
        Kernel::ThinPlate => 0,
        Kernel::Cubic => 1,
        Kernel::Linear => 2,
    }
}

fn operation_code(op: Operation) -> u8 {
    match op {
        Operation::Union => 0,
        Operation::Intersection => 1,
        Operation::Difference => 2,
    }
}

/// The three streams being read, and the file's name for errors.
struct Reader<'a> {
    meta: &'a [u8],
    occupancy: Occupancy<'a>,
    integers: &'a [u8],
    context: &'a str,
}

/// The points stream as read: the occupancy bytes as they are (version 1), or coded.
enum Occupancy<'a> {
    Bytes(&'a [u8]),
    Coded(occupancy::Decoder),
}

impl Occupancy<'_> {
    /// The points of the next octree, as [`octree::decode`].
    fn octree(&mut self, depth: u32, count: usize) -> std::result::Result<Vec<[u64; 3]>, String> {
        match self {
            Occupancy::Bytes(bytes) => octree::decode(|_| octree::next_byte(bytes), depth, count),
            Occupancy::Coded(decoder) => {
                decoder.start_octree();
                octree::decode(|d| decoder.mask(d), depth, count)
            }
        }
    }

    fn is_done(&self) -> bool {
        match self {
            Occupancy::Bytes(bytes) => bytes.is_empty(),
            Occupancy::Coded(decoder) => decoder.is_done(),
        }
    }
}

impl Reader<'_> {
    fn error(&self, message: String) -> Error {
        Error::invalid(self.context, message)
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let (head, rest) = self
            .meta
            .split_first_chunk::<N>()
            .ok_or_else(|| self.error("the file ends early (truncated?)".into()))?;
        self.meta = rest;
        Ok(*head)
    }

    fn u8(&mut self) -> Result<u8> {
        Ok(self.take::<1>()?[0])
    }

    fn f64(&mut self) -> Result<f64> {
        let v = f64::from_le_bytes(self.take::<8>()?);
        if v.is_finite() { Ok(v) } else { Err(self.error(format!("a number is {v}"))) }
    }

    fn f64s(&mut self, n: usize) -> Result<Vec<f64>> {
        (0..n).map(|_| self.f64()).collect()
    }

    fn varint(&mut self) -> Result<u64> {
        read_varint(&mut self.meta).map_err(|e| self.error(e))
    }

    /// A count of items of at least `bytes` bytes each in `stream_left` bytes: refused when the
    /// stream cannot hold them, so no count allocates beyond the file.
    fn count(&mut self, bytes: usize, stream_left: usize) -> Result<usize> {
        let n = self.varint()?;
        match usize::try_from(n) {
            Ok(n) if n.saturating_mul(bytes) <= stream_left => Ok(n),
            _ => Err(self.error(format!("a count of {n} items that the file cannot hold"))),
        }
    }

    /// Refuses a point set whose `count` integers (at least a byte each) the integers stream
    /// cannot hold, before its octree is read: coded, a point's place may take less than a bit,
    /// so the integers that follow the points bound their number.
    fn integers_for(&self, count: usize) -> Result<()> {
        if count > self.integers.len() {
            return Err(
                self.error(format!("{count} integers for a point set, more than the file holds"))
            );
        }
        Ok(())
    }

    fn int(&mut self) -> Result<i64> {
        read_varint(&mut self.integers).map(unzigzag).map_err(|e| self.error(e))
    }

    fn bounds(&mut self) -> Result<Aabb> {
        let min = DVec3::from_array([self.f64()?, self.f64()?, self.f64()?]);
        let max = DVec3::from_array([self.f64()?, self.f64()?, self.f64()?]);
        if !min.cmple(max).all() {
            return Err(self.error("the bounds are not finite with min <= max".into()));
        }
        Ok(Aabb { min, max })
    }

    fn grid(&mut self) -> Result<Grid> {
        let mut dims = [0usize; 3];
        for d in &mut dims {
            *d = usize::try_from(self.varint()?).unwrap_or(usize::MAX);
        }
        let origin = [self.f64()?, self.f64()?, self.f64()?];
        let voxel_size = self.f64()?;
        if dims.contains(&0) || dims.iter().any(|&d| d > 1 << 24) || voxel_size <= 0.0 {
            return Err(self.error("the grid's dims or voxel size are out of range".into()));
        }
        Ok(Grid { dims, origin, voxel_size })
    }

    fn shape(&mut self, context: &str, depth: usize) -> Result<Shape> {
        if depth > MAX_DEPTH {
            return Err(self.error(format!("CSG nested deeper than {MAX_DEPTH}")));
        }
        Ok(match self.u8()? {
            0 => Shape::Rbf(self.rbf(context)?),
            1 => {
                let base = self.rbf(&format!("{context}: level 0"))?;
                let count = self.count(9, self.meta.len())?;
                let levels = (0..count)
                    .map(|i| self.level(&format!("{context}: level {}", i + 1)))
                    .collect::<Result<Vec<_>>>()?;
                Shape::Levels(MultiScale::new(context, base, levels)?)
            }
            2 => Shape::Csg(self.csg(context, depth)?),
            tag => return Err(self.error(format!("unknown shape type {tag}"))),
        })
    }

    fn csg(&mut self, context: &str, depth: usize) -> Result<Composite> {
        let op = match self.u8()? {
            0 => Operation::Union,
            1 => Operation::Intersection,
            2 => Operation::Difference,
            code => return Err(self.error(format!("unknown CSG operation {code}"))),
        };
        let blend = self.f64()?;
        let count = self.count(57, self.meta.len())?;
        let mut children = Vec::with_capacity(count);
        for i in 0..count {
            let here = format!("{context}: csg child {}", i + 1);
            let scale = self.f64()?;
            let bounds = self.bounds()?;
            let shape = self.shape(&here, depth + 1)?;
            children.push(Child::with_scale(&here, shape, bounds, scale)?);
        }
        Composite::new(context, op, blend, children)
    }

    fn rbf(&mut self, context: &str) -> Result<Implicit> {
        let kernel = match self.u8()? {
            0 => Kernel::ThinPlate,
            1 => Kernel::Cubic,
            2 => Kernel::Linear,
            code => return Err(self.error(format!("unknown kernel {code}"))),
        };
        let dim = usize::from(self.u8()?);
        if !(2..=4).contains(&dim) {
            return Err(self.error(format!("dimension {dim} is not 2, 3 or 4")));
        }
        let n = self.count(1, self.meta.len() + self.integers.len())?;
        let translate = self.f64s(dim)?;
        let scale = self.f64()?;
        let polynomial = self.f64s(dim + 1)?;
        let residual = f64::from_le_bytes(self.take::<8>()?);
        let (constraints, weights, lattice) = match self.u8()? {
            0 => {
                let positions = self.f64s(n * dim)?;
                let values = self.f64s(n)?;
                let constraints = positions
                    .chunks_exact(dim)
                    .zip(&values)
                    .map(|(p, &v)| Constraint::new(p, v))
                    .collect();
                (constraints, self.f64s(n)?, None)
            }
            1 if dim == 3 => {
                let lattice = self.lattice()?;
                self.integers_for(2 * n)?;
                let keys = self.point_set(n)?;
                let values = self.multiples(n, lattice.value_step)?;
                let weights = self.multiples(n, lattice.weight_step)?;
                let constraints = keys
                    .iter()
                    .zip(&values)
                    .map(|(&k, &v)| Constraint::new(&lattice.point(k).to_array(), v))
                    .collect();
                (constraints, weights, Some(lattice))
            }
            coding => return Err(self.error(format!("unknown coding {coding} of a {dim}D rbf"))),
        };
        let normalization = Normalization { translate, scale };
        let implicit = Implicit::from_parts(
            context,
            dim,
            kernel,
            constraints,
            normalization,
            weights,
            polynomial,
            residual,
        )?;
        Ok(match lattice {
            Some(lattice) => implicit.on_lattice(lattice),
            None => implicit,
        })
    }

    fn level(&mut self, context: &str) -> Result<DetailLevel> {
        let radius = self.f64()?;
        let n = self.count(1, self.meta.len() + self.integers.len())?;
        let level = match self.u8()? {
            0 => {
                let coordinates = self.f64s(n * 3)?;
                let centres = coordinates.chunks_exact(3).map(DVec3::from_slice).collect();
                DetailLevel::new(context, radius, centres, self.f64s(n)?)?
            }
            1 => {
                let lattice = self.lattice()?;
                self.integers_for(n)?;
                let centres = self.point_set(n)?.into_iter().map(|k| lattice.point(k)).collect();
                let weights = self.multiples(n, lattice.weight_step)?;
                DetailLevel::new(context, radius, centres, weights)?.on_lattice(lattice)
            }
            coding => return Err(self.error(format!("unknown coding {coding} of a level"))),
        };
        Ok(level)
    }

    fn lattice(&mut self) -> Result<Lattice> {
        let origin = DVec3::from_array([self.f64()?, self.f64()?, self.f64()?]);
        let [cell, weight_step, value_step] = [self.f64()?, self.f64()?, self.f64()?];
        let lattice = Lattice { origin, cell, weight_step, value_step };
        if !lattice.is_valid() {
            return Err(self.error("a lattice step is not positive".into()));
        }
        Ok(lattice)
    }

    fn point_set(&mut self, n: usize) -> Result<Vec<[i64; 3]>> {
        let lo = [self.int()?, self.int()?, self.int()?];
        let depth = u32::from(self.u8()?);
        if depth > MORTON_BITS || lo.iter().any(|v| v.unsigned_abs() > 1 << 40) {
            return Err(self.error("a point set out of range".into()));
        }
        let offsets = self.occupancy.octree(depth, n).map_err(|e| self.error(e))?;
        Ok(offsets.into_iter().map(|o| [0, 1, 2].map(|a| lo[a] + o[a] as i64)).collect())
    }

    fn multiples(&mut self, n: usize, step: f64) -> Result<Vec<f64>> {
        (0..n).map(|_| Ok(self.int()? as f64 * step)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_survive_their_coding() {
        for v in [0i64, 1, -1, 63, -64, 1 << 40, -(1 << 40), i64::MAX, i64::MIN] {
            let mut bytes = Vec::new();
            push_varint(&mut bytes, zigzag(v));
            let mut read = &bytes[..];
            assert_eq!(unzigzag(read_varint(&mut read).unwrap()), v);
            assert!(read.is_empty());
        }
        assert!(read_varint(&mut &[0x80u8, 0x80][..]).is_err());
        assert!(read_varint(&mut &[0xffu8; 11][..]).is_err());
    }
}
