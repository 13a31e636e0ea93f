//! NumPy `.npy` files and `.npz` archives: volumes, point sets and samples that users load
//! with `numpy.load`.
//!
//! An `.npz` is a ZIP archive of `.npy` files, one per array, named after the array. It is
//! written here as stored (uncompressed) entries, the layout `numpy.savez` writes, by a small
//! writer rather than a ZIP crate: stored entries need only the headers and a CRC-32
//! (`crc32fast`, already built for PNG), and the archive has a fixed date, so the same arrays
//! give the same bytes. It is not ZIP64: an archive or array past 4 GB is refused.

use std::io::Write;
use std::path::Path;

use npyz::WriterBuilder;

use crate::error::{Error, Result};

/// Writes `data` as a C-order NumPy array of the given shape, atomically ([`crate::output`]).
pub fn write<T: npyz::AutoSerialize>(path: &Path, shape: &[u64], data: &[T]) -> Result<()> {
    let io = |e: std::io::Error| Error::io(path, e);
    crate::output::write_with(path, |out| {
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(out)
            .begin_nd()
            .map_err(io)?;
        writer.extend(data.iter()).map_err(io)?;
        writer.finish().map_err(io)
    })
}

/// `data` (the shape's number of values) as the bytes of a C-order NumPy `.npy` file of the
/// given shape.
pub(crate) fn to_bytes<T: npyz::AutoSerialize>(
    shape: &[u64],
    data: impl IntoIterator<Item = T>,
) -> Vec<u8> {
    // The header takes less than a few hundred bytes.
    let values = shape.iter().product::<u64>() as usize;
    let mut bytes = Vec::with_capacity(256 + values * size_of::<T>());
    let mut writer = npyz::WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .writer(&mut bytes)
        .begin_nd()
        .expect("writing to memory cannot fail");
    writer.extend(data).expect("writing to memory cannot fail");
    writer.finish().expect("writing to memory cannot fail");
    bytes
}

/// Writes an `.npz` archive of `arrays` (each a name, without `.npy`, and the bytes of its
/// `.npy` file, as [`to_bytes`] makes them), atomically ([`crate::output`]).
///
/// # Errors
/// The file cannot be written, or it would pass 4 GB.
pub(crate) fn write_npz(path: &Path, arrays: &[(&str, Vec<u8>)]) -> Result<()> {
    let too_large = || {
        Error::invalid(
            path.display().to_string(),
            "the archive would pass 4 GB, more than an .npz without ZIP64 holds; ask for fewer \
             points",
        )
    };
    let mut central = Vec::new();
    let mut offset = 0u64;
    let mut local = Vec::with_capacity(arrays.len());
    for (name, bytes) in arrays {
        let name = format!("{name}.npy");
        let entry = ZipEntry {
            name: name.as_bytes(),
            crc: crc32fast::hash(bytes),
            size: u32::try_from(bytes.len()).map_err(|_| too_large())?,
            offset: u32::try_from(offset).map_err(|_| too_large())?,
        };
        central.extend(entry.header(true));
        let header = entry.header(false);
        offset += (header.len() + bytes.len()) as u64;
        local.push(header);
    }
    let end = end_of_central_directory(
        arrays.len(),
        central.len(),
        u32::try_from(offset).map_err(|_| too_large())?,
    );
    let io = |e: std::io::Error| Error::io(path, e);
    crate::output::write_with(path, |out| {
        for (header, (_, bytes)) in local.iter().zip(arrays) {
            out.write_all(header).map_err(io)?;
            out.write_all(bytes).map_err(io)?;
        }
        out.write_all(&central).map_err(io)?;
        out.write_all(&end).map_err(io)
    })
}

/// One stored file of a ZIP archive.
struct ZipEntry<'a> {
    name: &'a [u8],
    crc: u32,
    size: u32,
    /// Where its local header starts.
    offset: u32,
}

impl ZipEntry<'_> {
    /// Its local header, or its central directory header (`central`).
    fn header(&self, central: bool) -> Vec<u8> {
        // Version 2.0, no flags, stored, 1980-01-01 00:00.
        const VERSION: u16 = 20;
        const DATE: u16 = (1 << 5) | 1;
        let mut h = Vec::with_capacity(46 + self.name.len());
        if central {
            h.extend(0x0201_4b50u32.to_le_bytes());
            h.extend(VERSION.to_le_bytes());
        } else {
            h.extend(0x0403_4b50u32.to_le_bytes());
        }
        for field in [VERSION, 0, 0, 0, DATE] {
            h.extend(field.to_le_bytes());
        }
        h.extend(self.crc.to_le_bytes());
        h.extend(self.size.to_le_bytes());
        h.extend(self.size.to_le_bytes());
        h.extend((self.name.len() as u16).to_le_bytes());
        h.extend(0u16.to_le_bytes());
        if central {
            // Comment length, disk, internal and external attributes, local header's offset.
            h.extend([0u8; 10]);
            h.extend(self.offset.to_le_bytes());
        }
        h.extend(self.name);
        h
    }
}

/// The end of a ZIP archive's central directory of `entries` entries and `size` bytes, which
/// starts at `offset`.
fn end_of_central_directory(entries: usize, size: usize, offset: u32) -> Vec<u8> {
    let mut e = Vec::with_capacity(22);
    e.extend(0x0605_4b50u32.to_le_bytes());
    e.extend([0u8; 4]);
    e.extend((entries as u16).to_le_bytes());
    e.extend((entries as u16).to_le_bytes());
    e.extend((size as u32).to_le_bytes());
    e.extend(offset.to_le_bytes());
    e.extend(0u16.to_le_bytes());
    e
}

/// Reads a 2D array of float32 or float64 values (N rows of `columns` values) as f64 rows.
pub fn read_rows(path: &Path) -> Result<(Vec<f64>, usize)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_rows_bytes(&bytes, path)
}

/// The longest header read, in bytes: `numpy.load`'s own limit (its `max_header_size`).
pub(crate) const MAX_HEADER: usize = 10_000;

/// The deepest nesting of brackets in a header read: a dictionary holding the shape's tuple.
pub(crate) const MAX_HEADER_NESTING: usize = 2;

/// Reads the bytes of a `.npy` file as [`read_rows`]; `path` names the file in messages.
pub(crate) fn read_rows_bytes(bytes: &[u8], path: &Path) -> Result<(Vec<f64>, usize)> {
    check_header(bytes, path)?;
    let npy = npyz::NpyFile::new(bytes)
        .map_err(|e| Error::parse(path, None, format!("not a NumPy .npy file: {e}")))?;
    let shape = npy.shape().to_vec();
    let columns = match shape.as_slice() {
        [_, c] => *c as usize,
        _ => {
            return Err(Error::parse(
                path,
                None,
                format!("expected a 2D array (N x columns), found shape {shape:?}"),
            ));
        }
    };
    if npy.order() != npyz::Order::C {
        return Err(Error::parse(
            path,
            None,
            "Fortran-order arrays are not supported; save with C order",
        ));
    }
    let bad = |e: std::io::Error| Error::parse(path, None, format!("damaged array data: {e}"));
    let dtype = npy.dtype();
    let needed =
        shape.iter().fold(dtype.num_bytes().unwrap_or(1) as u64, |n, &d| n.saturating_mul(d));
    if needed > bytes.len() as u64 {
        return Err(Error::parse(
            path,
            None,
            format!(
                "the header's shape {shape:?} needs {needed} bytes; the file has {}",
                bytes.len()
            ),
        ));
    }
    let values: Vec<f64> = match dtype.descr().trim_matches('\'') {
        "<f8" => npy.into_vec::<f64>().map_err(bad)?,
        "<f4" => npy.into_vec::<f32>().map_err(bad)?.into_iter().map(f64::from).collect(),
        other => {
            return Err(Error::parse(
                path,
                None,
                format!("expected float32 or float64 values, found dtype {other}"),
            ));
        }
    };
    Ok((values, columns))
}

/// Refuses a header longer than [`MAX_HEADER`], nested deeper than [`MAX_HEADER_NESTING`],
/// holding a backslash, or with a shape whose entries are not whole numbers or whose non-zero
/// entries multiply past 2^64, before npyz parses it. Found by fuzzing: npyz's parser takes
/// time exponential in the depth of unclosed brackets (a 200-byte header of 30 `[` ran past
/// the fuzzer's timeout), and it multiplies the shape's entries unchecked (an overflow, a
/// panic where overflow checks are on). The arrays read here
/// have a plain dtype, so no valid header of theirs nests deeper. Bytes too short to hold a
/// header are left to npyz's own error.
fn check_header(bytes: &[u8], path: &Path) -> Result<()> {
    let refuse = |what: String| Err(Error::parse(path, None, format!("NumPy header: {what}")));
    let (length, start) = match bytes.get(6) {
        Some(1) if bytes.len() >= 10 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        Some(2 | 3) if bytes.len() >= 12 => {
            (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12)
        }
        _ => return Ok(()),
    };
    if length > MAX_HEADER {
        return refuse(format!("{length} bytes long, more than the {MAX_HEADER} read"));
    }
    let header = &bytes[start..bytes.len().min(start + length)];
    let mut depth = 0usize;
    for &b in header {
        match b {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > MAX_HEADER_NESTING {
            return refuse(format!(
                "brackets nested deeper than {MAX_HEADER_NESTING} (a plain dtype's header is a \
                 dictionary holding the shape's tuple)"
            ));
        }
    }
    // An escape or a line continuation could spell a key (`'sha\x70e'`) that the shape check
    // below, a search of the text, would not see; NumPy writes neither.
    if header.contains(&b'\\') {
        return refuse("a backslash (an escape NumPy never writes in a header)".into());
    }
    check_shapes(&String::from_utf8_lossy(header)).or_else(refuse)
}

/// Checks every tuple (or list) following a `shape` key of the header's dictionary: its
/// entries are whole numbers, and the product of those that are not 0 fits in 64 bits (which
/// bounds every partial product npyz takes, in any order). The message says what is wrong.
fn check_shapes(header: &str) -> std::result::Result<(), String> {
    for (at, _) in header.match_indices("shape") {
        let rest = &header[at..];
        let Some(open) = rest.find(['(', '[']) else {
            continue;
        };
        let close = if rest.as_bytes()[open] == b'(' { ')' } else { ']' };
        let Some(length) = rest[open + 1..].find(close) else {
            continue;
        };
        let entries = &rest[open + 1..open + 1 + length];
        let mut product = 1u64;
        for entry in entries.split(',').map(str::trim).filter(|e| !e.is_empty()) {
            let n: u64 = entry.parse().map_err(|_| {
                format!("the shape's entry {entry:?} is not a whole number below 2^64")
            })?;
            if n != 0 {
                product = product
                    .checked_mul(n)
                    .ok_or_else(|| format!("the shape ({entries}) has more elements than 2^64"))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version 1 file of `header` (padded as NumPy pads it) and 12 f64 values.
    fn file(header: &str) -> Vec<u8> {
        let mut header = header.to_string();
        header += &" ".repeat(63 - (10 + header.len()) % 64);
        header.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend((header.len() as u16).to_le_bytes());
        bytes.extend(header.as_bytes());
        bytes.extend((0..12).flat_map(|i| f64::from(i).to_le_bytes()));
        bytes
    }

    #[test]
    fn a_plain_header_is_read() {
        let bytes = file("{'descr': '<f8', 'fortran_order': False, 'shape': (4, 3), }");
        let (values, columns) = read_rows_bytes(&bytes, Path::new("p.npy")).unwrap();
        assert_eq!((values.len(), columns), (12, 3));
        assert_eq!(values[11], 11.0);
    }

    /// The fuzzer's input (shape, then 30 unclosed `[`), on which npyz's parser ran past the
    /// fuzzer's timeout: refused at once, naming the file.
    #[test]
    fn deeply_nested_brackets_are_refused_before_parsing() {
        let header = format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': (4, 3),{} }}",
            "[".repeat(30)
        );
        let error = read_rows_bytes(&file(&header), Path::new("p.npy")).unwrap_err().to_string();
        assert!(error.contains("p.npy") && error.contains("nested deeper than 2"), "{error}");
    }

    /// The fuzzer's input: a shape whose entries npyz multiplied past 2^64 (a panic with
    /// overflow checks on), and one whose entry is no number.
    #[test]
    fn shapes_too_large_or_not_numbers_are_refused() {
        let huge = "{'descr': '<f8', 'fortran_order': False, \
                    'shape': (4000000000, 9000000000000, 3), }";
        let error = read_rows_bytes(&file(huge), Path::new("p.npy")).unwrap_err().to_string();
        assert!(error.contains("p.npy") && error.contains("more elements than 2^64"), "{error}");
        let odd = "{'descr': '<f2', 'fortran_order': False, 'shape': (4+++0009, 3), }";
        let error = read_rows_bytes(&file(odd), Path::new("p.npy")).unwrap_err().to_string();
        assert!(error.contains("\"4+++0009\" is not a whole number"), "{error}");
        // A list for the tuple, and a zero that would hide the overflow of the rest.
        for shape in ["[4000000000, 9000000000000, 3]", "(0, 1099511627776, 1099511627776)"] {
            let header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
            let error = read_rows_bytes(&file(&header), Path::new("p.npy")).unwrap_err();
            assert!(error.to_string().contains("more elements than 2^64"), "{shape}: {error}");
        }
    }

    /// The shape's key spelled with an escape (read by npyz as `shape`), holding a shape that
    /// overflows: the text search for `shape` would miss it, so any backslash is refused.
    #[test]
    fn escapes_in_the_header_are_refused() {
        let header = "{'descr': '<f8', 'fortran_order': False, \
                      'sha\\x70e': (4000000000, 9000000000000, 3), }";
        assert!(header.contains(r"'sha\x70e'"));
        let error = read_rows_bytes(&file(header), Path::new("p.npy")).unwrap_err().to_string();
        assert!(error.contains("p.npy") && error.contains("backslash"), "{error}");
    }

    #[test]
    fn a_header_longer_than_numpy_reads_is_refused() {
        let header = format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': (4, 3), 'x': '{}'}}",
            "a".repeat(MAX_HEADER)
        );
        let mut bytes = file("{}");
        bytes[6] = 2;
        let mut long = bytes[..8].to_vec();
        long.extend((header.len() as u32).to_le_bytes());
        long.extend(header.as_bytes());
        let error = read_rows_bytes(&long, Path::new("p.npy")).unwrap_err().to_string();
        assert!(error.contains("p.npy") && error.contains("more than the 10000 read"), "{error}");
    }
}
