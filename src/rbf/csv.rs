//! Constraint and point files in CSV: a header line naming the columns, then one row a line.
//!
//! Constraints: `x,y,value` (2D), `x,y,z,value` (3D) or `x,y,z,t,value` (4D), positions in the
//! mesh's units, values positive inside and negative outside. Points: `x,y`, `x,y,z` or
//! `x,y,z,t`. Blank lines are skipped. Every error names the file and the line.

use std::path::Path;

use super::Constraint;
use crate::error::{Error, Location, Result};

const AXES: [&str; 4] = ["x", "y", "z", "t"];

/// Reads constraints: returns the dimension (2, 3 or 4) and the constraints in file order.
pub fn read_constraints(path: &Path) -> Result<(usize, Vec<Constraint>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_constraints_bytes(&bytes, path)
}

/// Reads constraints from the bytes of a CSV file, as [`read_constraints`]; `path` names the
/// file in messages.
pub fn read_constraints_bytes(bytes: &[u8], path: &Path) -> Result<(usize, Vec<Constraint>)> {
    let (columns, rows) = read_table(bytes, path, true)?;
    let dim = columns - 1;
    let constraints =
        rows.chunks_exact(columns).map(|r| Constraint::new(&r[..dim], r[dim])).collect();
    Ok((dim, constraints))
}

/// Reads points: returns the dimension (2, 3 or 4) and the coordinates, point after point.
pub fn read_points(path: &Path) -> Result<(usize, Vec<f64>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_points_bytes(&bytes, path)
}

/// Reads points from the bytes of a CSV file, as [`read_points`]; `path` names the file in
/// messages.
pub fn read_points_bytes(bytes: &[u8], path: &Path) -> Result<(usize, Vec<f64>)> {
    read_table(bytes, path, false)
}

/// The expected header names for `dim` axes, with a value column or without.
fn header(dim: usize, value: bool) -> Vec<&'static str> {
    let mut names = AXES[..dim].to_vec();
    if value {
        names.push("value");
    }
    names
}

/// Reads a headed numeric table: the number of columns and the numbers, row after row.
fn read_table(bytes: &[u8], path: &Path, value: bool) -> Result<(usize, Vec<f64>)> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        Error::parse(path, Some(Location::Line(line)), "not UTF-8 text")
    })?;
    let mut lines =
        text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty());
    let expected: Vec<String> = (2..=4).map(|d| header(d, value).join(",")).collect();
    let Some((header_line, first)) = lines.next() else {
        return Err(Error::parse(
            path,
            None,
            format!("empty file: expected a header line such as {}", expected[1]),
        ));
    };
    let names: Vec<String> = first.split(',').map(|s| s.trim().to_ascii_lowercase()).collect();
    if !(2..=4).any(|d| names == header(d, value)) {
        return Err(Error::parse(
            path,
            Some(Location::Line(header_line)),
            format!(
                "expected the header {} (or {} / {}), found {first:?}",
                expected[1], expected[0], expected[2]
            ),
        ));
    }
    let columns = names.len();
    let mut rows = Vec::new();
    for (line, text) in lines {
        let at = Some(Location::Line(line));
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        if fields.len() != columns {
            return Err(Error::parse(
                path,
                at,
                format!("{} fields, expected {columns} ({})", fields.len(), names.join(",")),
            ));
        }
        for (field, name) in fields.iter().zip(&names) {
            let v: f64 = field.parse().map_err(|_| {
                Error::parse(path, at, format!("{name} is not a number: {field:?}"))
            })?;
            if !v.is_finite() {
                return Err(Error::parse(path, at, format!("{name} is not finite: {field:?}")));
            }
            rows.push(v);
        }
    }
    if rows.is_empty() {
        return Err(Error::parse(path, None, "no rows after the header"));
    }
    Ok((columns, rows))
}
