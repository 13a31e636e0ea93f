//! `implicitize view`: one self-contained HTML page that draws a model in a browser.
//!
//! The page (the template `view.html`, filled here) ray-marches the model's function in a
//! WebGL2 fragment shader: the GLSL of [`implicitize::shader::texture_source`], its centres and
//! weights in an RGBA32F texture. It marches through the lattice `render` marches through
//! ([`LatticeGeometry`]), sampled on the GPU, and crosses in one step the blocks of
//! [`BLOCK`]^3 cells where an upper bound of the function ([`implicitize::bound`], computed
//! here, split to half a cell where it cannot tell) is not positive, so no part of the surface
//! is skipped. It frames the model as `render` does, opens at the camera of
//! its address (`#view=AZIMUTH,ELEVATION`, `&panel=0` for the bare picture), orbits by dragging
//! and zooms by the wheel. With `--mesh` it also draws the mesh, beside the model or instead of
//! it. Everything (script, styles, numbers) is inside the one file, so it works offline.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use implicitize::bound::block_uppers;
use implicitize::model::Model;
use implicitize::render::{Camera, LatticeGeometry, March, march_bounds};
use implicitize::shape::Shape;
use implicitize::{Aabb, mesh::Mesh, output, shader};
use serde_json::{Value, json};

use super::common::{Progress, check_outputs, read_mesh};

/// The page's template; `/*IMPLICITIZE-DATA*/` becomes the page's data (JSON).
const TEMPLATE: &str = include_str!("view.html");

/// Where the data goes in the template.
const DATA_MARK: &str = "/*IMPLICITIZE-DATA*/";

/// Cells along each side of a block the page bounds the function over.
pub const BLOCK: usize = 4;

/// How many times a block is split in eight where its bound cannot tell its sign: down to
/// half a cell.
pub const SPLITS: u32 = 3;

/// The most triangles of a `--mesh` the page takes: 2 million triangles make a page of about
/// 50 MB, which browsers still open; decimate larger meshes first.
pub const MAX_MESH_TRIANGLES: usize = 2_000_000;

/// Arguments of `implicitize view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The model file (binary or JSON, from `fit`, `solve` or `csg`); it must be 3D.
    pub model: PathBuf,
    /// The page to write (HTML); open it in a browser with WebGL2.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also draw this mesh (OBJ, PLY, STL or OFF), beside the model, through the same camera.
    #[arg(long, value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// The fit report to show (JSON, from `fit --report`, which has the fit's time) instead of
    /// the one inside the model file.
    #[arg(long, value_name = "REPORT")]
    pub report: Option<PathBuf>,
}

/// Writes the page.
pub fn run(args: &ViewArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let model = Model::load(&args.model)?;
    let name = file_name(&args.model);
    let (glsl, texture) = shader::texture_source(&model, &name)?;
    let report = match &args.report {
        Some(path) => Some(read_report(path)?),
        None => model.report().cloned(),
    };
    let mut frame = model.bounds();
    let mesh = match &args.mesh {
        Some(path) => {
            let mesh = read_mesh(path, progress)?;
            let bounds = page_mesh_bounds(&mesh, path)?;
            frame = Aabb { min: frame.min.min(bounds.min), max: frame.max.max(bounds.max) };
            Some(mesh_data(&mesh, path))
        }
        None => None,
    };
    let lattice = LatticeGeometry::new(&march_bounds(&model), March::default())?;
    let (uppers, blocks) = block_uppers(model.shape(), &lattice, BLOCK, SPLITS);
    let upper: Vec<f32> = uppers.iter().map(|&u| upper_f32(u)).collect();
    let model_bytes = std::fs::metadata(&args.model).map(|m| m.len()).unwrap_or(0);
    let data = json!({
        "name": name,
        "view": Camera::DEFAULT_VIEW,
        "frame": box_json(&frame),
        "lattice": {
            "origin": lattice.origin.to_array(),
            "step": lattice.step,
            "cells": lattice.cells,
        },
        "blocks": { "block": BLOCK, "dims": blocks, "upper": base64(&f32_bytes(&upper)) },
        "glsl": glsl,
        "texture": {
            "width": texture.width,
            "height": texture.height,
            "data": base64(&f32_bytes(&texture.texels)),
        },
        "model": {
            "description": describe(model.shape()),
            "centres": centre_count(model.shape()),
            "bytes": model_bytes,
        },
        "report": report,
        "mesh": mesh,
    });
    let page = page(&data);
    output::write_bytes(&args.output, page.as_bytes())?;
    progress.line(format!("wrote {} ({} KiB)", args.output.display(), page.len() / 1024));
    Ok(())
}

/// The template with `data` in its place. `</` is written `<\/` (the same string to JSON) so
/// that nothing in the data can close the script element it sits in.
fn page(data: &Value) -> String {
    TEMPLATE.replacen(DATA_MARK, &data.to_string().replace("</", "<\\/"), 1)
}

/// The last component of `path`, for the page's title.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into())
}

/// Reads a fit report (any JSON object), naming the file in errors.
fn read_report(path: &Path) -> anyhow::Result<Value> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let report: Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a JSON fit report", path.display()))?;
    if !report.is_object() {
        bail!("{}: not a fit report (a JSON object)", path.display());
    }
    Ok(report)
}

/// The mesh's bounds, once it is known to fit in a page.
fn page_mesh_bounds(mesh: &Mesh, path: &Path) -> anyhow::Result<Aabb> {
    if mesh.triangles.len() > MAX_MESH_TRIANGLES {
        bail!(
            "{}: {} triangles is more than a page takes ({MAX_MESH_TRIANGLES}); decimate the mesh \
             first",
            path.display(),
            mesh.triangles.len()
        );
    }
    mesh.bounds().with_context(|| format!("{}: the mesh has no triangles", path.display()))
}

/// The mesh for the page: positions as f32 and triangle corners as u32, both little-endian in
/// base64.
fn mesh_data(mesh: &Mesh, path: &Path) -> Value {
    let positions: Vec<f32> =
        mesh.vertices.iter().flat_map(|v| v.to_array().map(|x| x as f32)).collect();
    let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
    json!({
        "name": file_name(path),
        "triangles": mesh.triangles.len(),
        "positions": base64(&f32_bytes(&positions)),
        "indices": base64(&indices),
    })
}

/// A box as `{"min": [..], "max": [..]}`.
fn box_json(b: &Aabb) -> Value {
    json!({ "min": b.min.to_array(), "max": b.max.to_array() })
}

/// What the model is, in a few words.
fn describe(shape: &Shape) -> String {
    match shape {
        Shape::Rbf(f) => format!("{} radial basis functions, kernel {}", f.len(), f.kernel()),
        Shape::Csg(c) => format!("CSG {} of {} shapes", c.operation(), c.children().len()),
        Shape::Levels(l) => format!(
            "{} radial basis functions, kernel {}, with {} detail levels of {} more",
            l.base().len(),
            l.base().kernel(),
            l.levels().len(),
            l.centre_count() - l.base().len()
        ),
        _ => "a shape".into(),
    }
}

/// The radial basis functions of every function in the shape.
fn centre_count(shape: &Shape) -> usize {
    match shape {
        Shape::Rbf(f) => f.len(),
        Shape::Csg(c) => c.children().iter().map(|child| centre_count(child.shape())).sum(),
        Shape::Levels(l) => l.centre_count(),
        _ => 0,
    }
}

/// An upper bound in f32 that stays one: positive bounds stay positive, and one that is not a
/// number (nothing known) becomes infinite.
fn upper_f32(hi: f64) -> f32 {
    if hi.is_nan() {
        f32::INFINITY
    } else if hi > 0.0 {
        (hi as f32).max(f32::MIN_POSITIVE)
    } else {
        hi as f32
    }
}

/// Little-endian bytes of f32 numbers.
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Standard base64 with padding (RFC 4648), what the page's `atob` reads.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::base64;

    #[test]
    fn base64_matches_rfc_4648_examples() {
        let cases =
            [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foobar", "Zm9vYmFy")];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
    }
}
