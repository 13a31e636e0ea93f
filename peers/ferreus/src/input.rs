//! Reading and checking the peer's inputs (constraints CSV, points `.npy`) and writing its
//! values; every error names the file (and the line, for CSV).
//!
//! The checks are those `ferreus_rbf` does not make: it panics on non-finite numbers, drops
//! points that (nearly) repeat an earlier one without saying so unless asked, and cannot fit a
//! linear polynomial to points that all lie on one plane (in 2D, one line).

use std::collections::HashMap;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Constraints read from a CSV file.
pub struct Constraints {
    /// 2 or 3.
    pub dim: usize,
    /// `dim` coordinates per constraint.
    pub positions: Vec<f64>,
    /// One value per constraint.
    pub values: Vec<f64>,
}

/// Reads and checks constraints: a header `x,y,z,value` (or `x,y,value`), then one row a line,
/// blank lines skipped, as `implicitize solve` reads them.
pub fn read_constraints(path: &Path) -> Result<Constraints, String> {
    let file = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("{file}: {e}"))?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        format!("{file} (line {line}): not UTF-8 text")
    })?;
    let mut lines =
        text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty());
    let (header_line, header) = lines.next().ok_or_else(|| format!("{file}: empty file"))?;
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_ascii_lowercase()).collect();
    let dim = match names.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["x", "y", "z", "value"] => 3,
        ["x", "y", "value"] => 2,
        _ => {
            return Err(format!(
                "{file} (line {header_line}): expected the header x,y,z,value (or x,y,value), found {header:?}"
            ));
        }
    };
    let mut positions = Vec::new();
    let mut values = Vec::new();
    let mut rows = Vec::new(); // the line of each constraint
    for (line, row) in lines {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != dim + 1 {
            return Err(format!(
                "{file} (line {line}): {} fields, expected {} ({})",
                fields.len(),
                dim + 1,
                names.join(",")
            ));
        }
        for (k, (field, name)) in fields.iter().zip(&names).enumerate() {
            let v: f64 = field
                .parse()
                .map_err(|_| format!("{file} (line {line}): {name} is not a number: {field:?}"))?;
            if !v.is_finite() {
                return Err(format!("{file} (line {line}): {name} is not finite: {field:?}"));
            }
            if k < dim { positions.push(v) } else { values.push(v) }
        }
        rows.push(line);
    }
    if values.len() < dim + 1 {
        return Err(format!(
            "{file}: {} constraints; a thin-plate spline with a linear polynomial needs at least {}",
            values.len(),
            dim + 1
        ));
    }
    // Repeated positions: the crate would silently keep only the first.
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::with_capacity(values.len());
    for (i, p) in positions.chunks_exact(dim).enumerate() {
        // +0.0 and -0.0 are the same position.
        let key = p.iter().map(|&x| (x + 0.0).to_bits()).collect();
        if let Some(&j) = seen.get(&key) {
            return Err(format!(
                "{file} (lines {} and {}): two constraints at the same position",
                rows[j], rows[i]
            ));
        }
        seen.insert(key, i);
    }
    check_spans_space(&positions, dim).map_err(|m| format!("{file}: {m}"))?;
    Ok(Constraints { dim, positions, values })
}

/// An error unless the points span `dim` dimensions: greedily the point farthest from the
/// first, then from the line through both, then (3D) from the plane through the three, each
/// farther than 1e-9 of the extent.
fn check_spans_space(positions: &[f64], dim: usize) -> Result<(), String> {
    let points: Vec<[f64; 3]> = positions
        .chunks_exact(dim)
        .map(|p| [p[0], p[1], if dim == 3 { p[2] } else { 0.0 }])
        .collect();
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let farthest = |distance: &dyn Fn([f64; 3]) -> f64| {
        points
            .iter()
            .map(|&p| (distance(p), p))
            .fold((0.0, points[0]), |a, b| if b.0 > a.0 { b } else { a })
    };
    let o = points[0];
    let (extent, a) = farthest(&|p| dot(sub(p, o), sub(p, o)).sqrt());
    let tiny = 1e-9 * extent;
    if !(extent > 0.0) {
        return Err("all constraints are at one position".to_string());
    }
    let u = sub(a, o);
    let (off_line, b) = farthest(&|p| {
        let c = cross(u, sub(p, o));
        dot(c, c).sqrt() / extent
    });
    if !(off_line > tiny) {
        return Err(
            "all constraints lie on one line: a linear polynomial is not determined".to_string()
        );
    }
    if dim == 3 {
        let n = cross(u, sub(b, o));
        let n_len = dot(n, n).sqrt();
        let (off_plane, _) = farthest(&|p| dot(n, sub(p, o)).abs() / n_len);
        if !(off_plane > tiny) {
            return Err("all constraints lie on one plane: a linear polynomial is not determined"
                .to_string());
        }
    }
    Ok(())
}

/// Reads points: a C-order N x `dim` float32 or float64 `.npy`, every coordinate finite.
pub fn read_points(path: &Path, dim: usize) -> Result<Vec<f64>, String> {
    let file = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("{file}: {e}"))?;
    let npy = npyz::NpyFile::new(&bytes[..])
        .map_err(|e| format!("{file}: not a NumPy .npy file: {e}"))?;
    let shape = npy.shape().to_vec();
    if shape.len() != 2 || shape[1] != dim as u64 {
        return Err(format!("{file}: expected an N x {dim} array, found shape {shape:?}"));
    }
    if npy.order() != npyz::Order::C {
        return Err(format!("{file}: Fortran-order arrays are not supported; save with C order"));
    }
    let bad = |e: std::io::Error| format!("{file}: damaged array data: {e}");
    let dtype = npy.dtype().descr();
    let values: Vec<f64> = match dtype.trim_matches('\'') {
        "<f8" => npy.into_vec::<f64>().map_err(bad)?,
        "<f4" => npy.into_vec::<f32>().map_err(bad)?.into_iter().map(f64::from).collect(),
        other => {
            return Err(format!("{file}: expected float32 or float64 values, found dtype {other}"));
        }
    };
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("{file}: point {} has a non-finite coordinate", i / dim));
    }
    Ok(values)
}

/// Writes values as a float64 `.npy` array of length N.
pub fn write_values(path: &Path, values: &[f64]) -> Result<(), String> {
    let io = |e: std::io::Error| format!("{}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = BufWriter::new(file);
    {
        use npyz::WriterBuilder;
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&[values.len() as u64])
            .writer(&mut out)
            .begin_nd()
            .map_err(io)?;
        writer.extend(values.iter()).map_err(io)?;
        writer.finish().map_err(io)?;
    }
    out.flush().map_err(io)
}
