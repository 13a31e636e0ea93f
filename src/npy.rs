//! NumPy `.npy` files: volumes and point sets that users load with `numpy.load`.

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

/// Reads a 2D array of float32 or float64 values (N rows of `columns` values) as f64 rows.
pub fn read_rows(path: &Path) -> Result<(Vec<f64>, usize)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_rows_bytes(&bytes, path)
}

/// Reads the bytes of a `.npy` file as [`read_rows`]; `path` names the file in messages.
pub fn read_rows_bytes(bytes: &[u8], path: &Path) -> Result<(Vec<f64>, usize)> {
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
