//! Shader source of a model: its function and gradient in GLSL or WGSL, to draw or combine it
//! on a GPU (the page of `implicitize view`, Shadertoy-style work, a game's shaders).
//!
//! [`source`] writes two functions of a point `p` in the mesh's units:
//!
//! ```text
//! GLSL:  float implicitize_value(vec3 p)       vec3 implicitize_gradient(vec3 p)
//! WGSL:  fn implicitize_value(p: vec3<f32>) -> f32
//!        fn implicitize_gradient(p: vec3<f32>) -> vec3<f32>
//! ```
//!
//! with the crate's sign convention: **inside positive, outside negative**, so the gradient
//! points inside. The model's numbers are constants in the source: for each variational
//! implicit function, one array of `vec4` holding a centre (`xyz`) and its weight (`w`), the
//! normalization and the linear polynomial. A CSG composite ([`crate::shape::csg`]) becomes one
//! function per node, combining its children exactly as [`crate::shape::csg::Composite`] does (each
//! child divided by its distance scale, Quilez's smooth minimum of the blend radius), so the
//! exported function is the model's. The GLSL has no `#version` line: it compiles as GLSL ES
//! 3.00 (WebGL2) and desktop GLSL 3.30 and later.
//!
//! ## Single precision
//! A GPU sums in f32. Each function is evaluated in its normalized coordinates
//! `q = (p - translate) / scale` (centres within about a unit of the origin), where the terms
//! of the sum stay within a few units of the result. Measured on a GPU (SwiftShader) against
//! the f64 evaluation, over a grid around the bounds: 4e-6 of the value range on the bunny,
//! 3e-5 on a blended union of it with a ball, within the `1e-4` the tests ask. Points far from the origin (a mesh placed at 1e6) lose digits in `p` itself
//! before the shader sees it: pass points relative to the model there.
//!
//! ## The texture layout (large models)
//! A few thousand constants are fine for a compiler; beyond that, and in the viewer, the
//! centres live in a texture ([`texture_source`]): an RGBA32F 2D texture of
//! 1,024 texels per row, read with `texelFetch` and no filtering; texel `i` is at
//! column `i % TEXTURE_WIDTH`, row `i / TEXTURE_WIDTH`, and holds the normalized centre
//! `(c - translate) / scale` in `rgb` and the weight in `a`. The functions of a composite take
//! consecutive runs of texels, in the order of the model file's tree (depth first), each at the
//! offset written into its loop. The sampler is the uniform `implicitize_centres`.
//!
//! ## Detail levels
//! A model with detail levels ([`crate::rbf::MultiScale`]) is level 0's function plus one function per
//! level, evaluated in level 0's normalized coordinates. A level is never read by looping over
//! its centres: its [`DetailLevel::grid_index`] (a dense uniform grid over its supports, at most
//! `CONSTANT_INDEX_CELLS` cells in the source, `TEXTURE_INDEX_CELLS` (64^3) in the texture, each
//! cell listing the centres whose support meets it) gives the point's one cell, whose run of
//! entries names the centres whose Wendland terms are summed. In the source the level's
//! normalized centres and weights, cell starts and entries are constant arrays; in the texture
//! they follow level 0's centres in that order, the centres one a texel, the starts and
//! entries one number a texel in `r` (exact in f32 below 2^24).

use std::collections::BTreeSet;
use std::fmt::Write as _;

use crate::error::{Error, Result};
use crate::model::Model;
use crate::rbf::MultiScale;
use crate::rbf::{DetailLevel, Implicit, Kernel, Normalization};
use crate::shape::Shape;
use crate::shape::csg::{Composite, Operation};

/// The shading language of [`source`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Language {
    /// GLSL: ES 3.00 (WebGL2) or desktop 3.30 and later.
    Glsl,
    /// WGSL (WebGPU).
    Wgsl,
}

/// Texels per row of the centre texture (see the [module doc](self)).
pub(crate) const TEXTURE_WIDTH: usize = 1024;

/// At most about this many cells in the grid index of a detail level whose numbers are
/// constants in the source ([`source`]): 32^3.
pub(crate) const CONSTANT_INDEX_CELLS: usize = 1 << 15;

/// At most about this many cells in the grid index of a detail level in the texture
/// ([`texture_source`]): 64^3.
pub(crate) const TEXTURE_INDEX_CELLS: usize = 1 << 18;

/// The centres and weights of every function of a model, laid out as the [module
/// doc](self) says: `width * height` RGBA texels, row after row, padded with zeros.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Texels per row (1,024).
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `4 * width * height` numbers: normalized centre `x, y, z`, then the weight, per texel.
    pub texels: Vec<f32>,
}

/// The source of `implicitize_value` and `implicitize_gradient` for `model` in `language`,
/// with every number a constant, after a comment that says the sign convention, the units and
/// the model's bounds. `name` (the model's file, say) is written into that comment.
///
/// # Errors
/// A model that is not 3D, or whose numbers do not fit in f32.
pub fn source(model: &Model, name: &str, language: Language) -> Result<String> {
    check(model, name)?;
    Ok(Emitter::new(language, Storage::Constants).program(model, name))
}

/// The GLSL source of `implicitize_value` and `implicitize_gradient` for `model` reading its
/// centres from the texture [`Texture`] lays out, bound to the uniform
/// `highp sampler2D implicitize_centres`, and that texture's contents. What the viewer of
/// `implicitize view` draws.
///
/// # Errors
/// As [`source`].
pub fn texture_source(model: &Model, name: &str) -> Result<(String, Texture)> {
    check(model, name)?;
    let mut emitter = Emitter::new(Language::Glsl, Storage::Texture);
    let source = emitter.program(model, name);
    let height = emitter.texels.len().div_ceil(4 * TEXTURE_WIDTH).max(1);
    let mut texels = emitter.texels;
    texels.resize(4 * TEXTURE_WIDTH * height, 0.0);
    Ok((source, Texture { width: TEXTURE_WIDTH, height, texels }))
}

/// Where the centres of the functions go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Storage {
    /// Constant arrays in the source.
    Constants,
    /// The texture `implicitize_centres`.
    Texture,
}

/// Writes the functions of a shape tree, one node after another, children first.
struct Emitter {
    language: Language,
    storage: Storage,
    /// The nodes' functions, in order.
    code: String,
    /// Nodes written so far.
    nodes: usize,
    /// The centre texture's numbers so far (texture storage).
    texels: Vec<f32>,
    /// The kernels the functions use.
    kernels: BTreeSet<&'static str>,
    /// Whether a composite needs the combining helpers.
    composite: bool,
}

impl Emitter {
    fn new(language: Language, storage: Storage) -> Emitter {
        Emitter {
            language,
            storage,
            code: String::new(),
            nodes: 0,
            texels: Vec::new(),
            kernels: BTreeSet::new(),
            composite: false,
        }
    }

    /// The whole program: header, helpers, nodes, and the two entry points.
    fn program(&mut self, model: &Model, name: &str) -> String {
        let root = self.node(model.shape());
        let mut out = header(model, name, self.language, self.storage);
        if self.storage == Storage::Texture {
            out.push_str("uniform highp sampler2D implicitize_centres;\n\n");
        }
        for kernel in &self.kernels {
            out.push_str(kernel_functions(kernel, self.language));
        }
        if self.composite {
            out.push_str(combine_functions(self.language));
        }
        out.push_str(&self.code);
        let entry = match self.language {
            Language::Glsl => format!(
                "float implicitize_value(vec3 p) {{ return implicitize_node{root}_value(p); }}\n\
                 vec3 implicitize_gradient(vec3 p) {{ return implicitize_node{root}(p).xyz; }}\n"
            ),
            Language::Wgsl => format!(
                "fn implicitize_value(p: vec3<f32>) -> f32 {{ return implicitize_node{root}_value(p); }}\n\
                 fn implicitize_gradient(p: vec3<f32>) -> vec3<f32> {{ return implicitize_node{root}(p).xyz; }}\n"
            ),
        };
        out.push_str(&entry);
        out
    }

    /// Writes the functions of `shape` (children first) and returns its node number.
    fn node(&mut self, shape: &Shape) -> usize {
        match shape {
            Shape::Rbf(implicit) => self.rbf(implicit),
            Shape::Csg(composite) => self.csg(composite),
            Shape::Levels(levels) => self.levels(levels),
        }
    }

    /// The next node number.
    fn next(&mut self) -> usize {
        self.nodes += 1;
        self.nodes - 1
    }

    /// Writes the value and value-and-gradient functions of one variational implicit function.
    fn rbf(&mut self, implicit: &Implicit) -> usize {
        let id = self.next();
        let lang = self.language;
        let centres = normalized_centres(implicit);
        let n = centres.len();
        let _ = writeln!(
            self.code,
            "// node {id}: {n} radial basis functions, evaluated at q = (p - translate) / scale"
        );
        let fetch = match self.storage {
            Storage::Constants => {
                self.code.push_str(&constant_array_named(
                    &format!("IMPLICITIZE_RBF{id}"),
                    &centres,
                    lang,
                ));
                format!("IMPLICITIZE_RBF{id}[j]")
            }
            Storage::Texture => {
                let offset = self.texels.len() / 4;
                self.texels.extend(centres.iter().flatten());
                format!(
                    "texelFetch(implicitize_centres, ivec2((j + {offset}) % {TEXTURE_WIDTH}, \
                     (j + {offset}) / {TEXTURE_WIDTH}), 0)"
                )
            }
        };
        let kernel = kernel_name(implicit.kernel());
        self.kernels.insert(kernel);
        let norm = implicit.normalization();
        let t = &norm.translate;
        let parts = RbfParts {
            id,
            n,
            fetch,
            kernel,
            translate: vec3(lang, t[0], t[1], t[2]),
            inv_scale: number(1.0 / norm.scale),
            p0: number(implicit.polynomial()[0]),
            linear: {
                let p = implicit.polynomial();
                vec3(lang, p[1], p[2], p[3])
            },
        };
        self.code.push_str(&parts.functions(lang));
        id
    }

    /// Writes the functions of a model with detail levels: level 0's node, one function per
    /// detail level reading its grid index, and the node that sums them.
    fn levels(&mut self, levels: &MultiScale) -> usize {
        let base = self.rbf(levels.base());
        let id = self.next();
        let lang = self.language;
        let norm = levels.base().normalization();
        let t = &norm.translate;
        let (translate, inv_scale) = (vec3(lang, t[0], t[1], t[2]), number(1.0 / norm.scale));
        let mut calls = Vec::new();
        for (k, level) in levels.levels().iter().enumerate() {
            if level.centres().is_empty() {
                continue;
            }
            let name = format!("implicitize_node{id}_level{k}");
            let code = self.level(&name, level, norm);
            self.code.push_str(&code);
            calls.push(format!("{name}(q)"));
        }
        let sum = match (calls.is_empty(), lang) {
            (false, _) => calls.join(" + "),
            (true, Language::Glsl) => "vec4(0.0)".into(),
            (true, Language::Wgsl) => "vec4<f32>(0.0)".into(),
        };
        let (sig_value, sig_both) = signatures(lang, id);
        let (q, l, b) = match lang {
            Language::Glsl => ("vec3 q", "vec4 l", "vec4 b"),
            Language::Wgsl => ("let q", "let l", "let b"),
        };
        let _ = write!(
            self.code,
            "// node {id}: level 0 (node {base}) plus {} detail levels, at q = (p - translate) / scale\n\
             {sig_value} {{\n\
             \x20   {q} = (p - {translate}) * {inv_scale};\n\
             \x20   {l} = {sum};\n\
             \x20   return implicitize_node{base}_value(p) + l.w;\n\
             }}\n\
             {sig_both} {{\n\
             \x20   {q} = (p - {translate}) * {inv_scale};\n\
             \x20   {l} = {sum};\n\
             \x20   {b} = implicitize_node{base}(p);\n\
             \x20   return {};\n\
             }}\n\n",
            calls.len(),
            vec4_of(lang, &format!("b.xyz + l.xyz * {inv_scale}"), "b.w + l.w"),
        );
        id
    }

    /// The function `name(q)` of one detail level in level 0's normalized coordinates `q`: its
    /// gradient (in `q`) and value, summed over the centres its grid index lists for `q`'s cell.
    fn level(&mut self, name: &str, level: &DetailLevel, norm: &Normalization) -> String {
        let lang = self.language;
        let max_cells = match self.storage {
            Storage::Constants => CONSTANT_INDEX_CELLS,
            Storage::Texture => TEXTURE_INDEX_CELLS,
        };
        let index = level.grid_index(max_cells);
        let centres: Vec<[f32; 4]> = level
            .centres()
            .iter()
            .zip(level.weights())
            .map(|(c, &w)| {
                let mut q = [0.0; 3];
                norm.apply(&c.to_array(), &mut q);
                [q[0] as f32, q[1] as f32, q[2] as f32, w as f32]
            })
            .collect();
        let upper = name.to_uppercase();
        let (centre, first, end) = match self.storage {
            Storage::Constants => {
                let mut arrays = constant_array_named(&format!("{upper}_CENTRES"), &centres, lang);
                arrays.push_str(&int_array(&format!("{upper}_STARTS"), &index.starts, lang));
                let entries =
                    if index.entries.is_empty() { vec![0] } else { index.entries.clone() };
                arrays.push_str(&int_array(&format!("{upper}_ENTRIES"), &entries, lang));
                self.code.push_str(&arrays);
                (
                    format!("{upper}_CENTRES[{upper}_ENTRIES[e]]"),
                    format!("{upper}_STARTS[cell]"),
                    format!("{upper}_STARTS[cell + 1]"),
                )
            }
            Storage::Texture => {
                let centre_offset = self.texels.len() / 4;
                self.texels.extend(centres.iter().flatten());
                let starts_offset = self.texels.len() / 4;
                self.texels.extend(index.starts.iter().flat_map(|&i| [i as f32, 0.0, 0.0, 0.0]));
                let entries_offset = self.texels.len() / 4;
                self.texels.extend(index.entries.iter().flat_map(|&i| [i as f32, 0.0, 0.0, 0.0]));
                let texel = |at: String| {
                    format!(
                        "texelFetch(implicitize_centres, ivec2(({at}) % {TEXTURE_WIDTH}, ({at}) / {TEXTURE_WIDTH}), 0)"
                    )
                };
                (
                    texel(format!(
                        "int({}.r) + {centre_offset}",
                        texel(format!("e + {entries_offset}"))
                    )),
                    format!("int({}.r)", texel(format!("cell + {starts_offset}"))),
                    format!("int({}.r)", texel(format!("cell + 1 + {starts_offset}"))),
                )
            }
        };
        let o = index.origin;
        let mut origin = [0.0; 3];
        norm.apply(&o.to_array(), &mut origin);
        let origin = vec3(lang, origin[0], origin[1], origin[2]);
        let inv_side = number(norm.scale / index.side);
        let radius = level.radius() / norm.scale;
        let (inv_radius, inv_radius2) = (number(1.0 / radius), number(1.0 / (radius * radius)));
        let [dx, dy, dz] = index.dims;
        let dims = vec3(lang, dx as f64, dy as f64, dz as f64);
        let body = match lang {
            Language::Glsl => format!(
                "vec4 {name}(vec3 q) {{\n\
                 \x20   vec3 g = floor((q - {origin}) * {inv_side});\n\
                 \x20   if (any(lessThan(g, vec3(0.0))) || any(greaterThanEqual(g, {dims}))) {{ return vec4(0.0); }}\n\
                 \x20   ivec3 c = ivec3(g);\n\
                 \x20   int cell = (c.z * {dy} + c.y) * {dx} + c.x;\n\
                 \x20   vec4 f = vec4(0.0);\n\
                 \x20   int end = {end};\n\
                 \x20   for (int e = {first}; e < end; e++) {{\n\
                 \x20       vec4 cw = {centre};\n\
                 \x20       vec3 d = q - cw.xyz;\n\
                 \x20       float t = length(d) * {inv_radius};\n\
                 \x20       if (t < 1.0) {{\n\
                 \x20           float s = 1.0 - t;\n\
                 \x20           float s3 = s * s * s;\n\
                 \x20           f += cw.w * vec4(-20.0 * s3 * {inv_radius2} * d, s3 * s * (4.0 * t + 1.0));\n\
                 \x20       }}\n\
                 \x20   }}\n\
                 \x20   return f;\n\
                 }}\n\n"
            ),
            Language::Wgsl => format!(
                "fn {name}(q: vec3<f32>) -> vec4<f32> {{\n\
                 \x20   let g = floor((q - {origin}) * {inv_side});\n\
                 \x20   if (any(g < vec3<f32>(0.0)) || any(g >= {dims})) {{ return vec4<f32>(0.0); }}\n\
                 \x20   let c = vec3<i32>(g);\n\
                 \x20   let cell = (c.z * {dy} + c.y) * {dx} + c.x;\n\
                 \x20   var f = vec4<f32>(0.0);\n\
                 \x20   let end = {end};\n\
                 \x20   for (var e = {first}; e < end; e++) {{\n\
                 \x20       let cw = {centre};\n\
                 \x20       let d = q - cw.xyz;\n\
                 \x20       let t = length(d) * {inv_radius};\n\
                 \x20       if (t < 1.0) {{\n\
                 \x20           let s = 1.0 - t;\n\
                 \x20           let s3 = s * s * s;\n\
                 \x20           f += cw.w * vec4<f32>(-20.0 * s3 * {inv_radius2} * d, s3 * s * (4.0 * t + 1.0));\n\
                 \x20       }}\n\
                 \x20   }}\n\
                 \x20   return f;\n\
                 }}\n\n"
            ),
        };
        format!(
            "// {name}: {} Wendland C2 functions of support radius {} (mesh units), through a grid \
             index of {dx} x {dy} x {dz} cells\n{body}",
            centres.len(),
            level.radius(),
        )
    }

    /// Writes the functions of a composite node over its children's.
    fn csg(&mut self, composite: &Composite) -> usize {
        self.composite = true;
        let children: Vec<(usize, f64)> =
            composite.children().iter().map(|c| (self.node(c.shape()), c.scale())).collect();
        let id = self.next();
        let op = match composite.operation() {
            Operation::Union => 0,
            Operation::Intersection => 1,
            Operation::Difference => 2,
        };
        let k = number(composite.blend());
        let lang = self.language;
        let zero = match lang {
            Language::Glsl => "vec3(0.0)",
            Language::Wgsl => "vec3<f32>(0.0)",
        };
        let mut value = String::new();
        let mut both = String::new();
        for (i, &(child, scale)) in children.iter().enumerate() {
            let s = number(scale);
            let v = vec4_of(lang, zero, &format!("implicitize_node{child}_value(p) / {s}"));
            let g = format!("implicitize_node{child}(p) / {s}");
            if i == 0 {
                let _ = writeln!(value, "    {} = {v};", declare(lang, "a"));
                let _ = writeln!(both, "    {} = {g};", declare(lang, "a"));
            } else {
                let _ = writeln!(value, "    a = implicitize_combine(a, {v}, {op}, {k});");
                let _ = writeln!(both, "    a = implicitize_combine(a, {g}, {op}, {k});");
            }
        }
        let (sig_value, sig_both) = signatures(lang, id);
        let _ = write!(
            self.code,
            "// node {id}: {} of {} shapes, blend radius {} (mesh units)\n\
             {sig_value} {{\n{value}    return a.w;\n}}\n{sig_both} {{\n{both}    return a;\n}}\n\n",
            composite.operation(),
            children.len(),
            composite.blend(),
        );
        id
    }
}

/// A variable declaration: `vec4 a` or `var a`.
fn declare(lang: Language, name: &str) -> String {
    match lang {
        Language::Glsl => format!("vec4 {name}"),
        Language::Wgsl => format!("var {name}"),
    }
}

/// `vec4(xyz, w)` in the language.
fn vec4_of(lang: Language, xyz: &str, w: &str) -> String {
    match lang {
        Language::Glsl => format!("vec4({xyz}, {w})"),
        Language::Wgsl => format!("vec4<f32>({xyz}, {w})"),
    }
}

/// `vec3(x, y, z)` of three numbers in the language.
fn vec3(lang: Language, x: f64, y: f64, z: f64) -> String {
    let (x, y, z) = (number(x), number(y), number(z));
    match lang {
        Language::Glsl => format!("vec3({x}, {y}, {z})"),
        Language::Wgsl => format!("vec3<f32>({x}, {y}, {z})"),
    }
}

/// The signatures of node `id`'s value function and value-and-gradient function.
fn signatures(lang: Language, id: usize) -> (String, String) {
    match lang {
        Language::Glsl => (
            format!("float implicitize_node{id}_value(vec3 p)"),
            format!("vec4 implicitize_node{id}(vec3 p)"),
        ),
        Language::Wgsl => (
            format!("fn implicitize_node{id}_value(p: vec3<f32>) -> f32"),
            format!("fn implicitize_node{id}(p: vec3<f32>) -> vec4<f32>"),
        ),
    }
}

/// What the functions of one variational implicit function are made of.
struct RbfParts {
    id: usize,
    n: usize,
    /// The expression of centre `j`'s texel.
    fetch: String,
    kernel: &'static str,
    translate: String,
    inv_scale: String,
    p0: String,
    linear: String,
}

impl RbfParts {
    /// `implicitize_nodeID_value(p)`, the value, and `implicitize_nodeID(p)`, the gradient (in
    /// mesh units) in `xyz` and the value in `w`.
    fn functions(&self, lang: Language) -> String {
        let RbfParts { id, n, fetch, kernel, translate, inv_scale, p0, linear } = self;
        let (sig_value, sig_both) = signatures(lang, *id);
        let (q, f, lp, c, d, r2, fv) = match lang {
            Language::Glsl => (
                "vec3 q",
                "float f",
                format!("for (int j = 0; j < {n}; j++)"),
                "vec4 c",
                "vec3 d",
                "float r2",
                format!("vec4 f = vec4({linear}, {p0} + dot({linear}, q));"),
            ),
            Language::Wgsl => (
                "let q",
                "var f",
                format!("for (var j = 0; j < {n}; j++)"),
                "let c",
                "let d",
                "let r2",
                format!("var f = vec4<f32>({linear}, {p0} + dot({linear}, q));"),
            ),
        };
        let grad = vec4_of(
            lang,
            &format!("implicitize_dphi_{kernel}(r2) * d"),
            &format!("implicitize_phi_{kernel}(r2)"),
        );
        format!(
            "{sig_value} {{\n\
             \x20   {q} = (p - {translate}) * {inv_scale};\n\
             \x20   {f} = {p0} + dot({linear}, q);\n\
             \x20   {lp} {{\n\
             \x20       {c} = {fetch};\n\
             \x20       {d} = q - c.xyz;\n\
             \x20       f += c.w * implicitize_phi_{kernel}(dot(d, d));\n\
             \x20   }}\n\
             \x20   return f;\n\
             }}\n\
             {sig_both} {{\n\
             \x20   {q} = (p - {translate}) * {inv_scale};\n\
             \x20   {fv}\n\
             \x20   {lp} {{\n\
             \x20       {c} = {fetch};\n\
             \x20       {d} = q - c.xyz;\n\
             \x20       {r2} = dot(d, d);\n\
             \x20       f += c.w * {grad};\n\
             \x20   }}\n\
             \x20   return {};\n\
             }}\n\n",
            vec4_of(lang, &format!("f.xyz * {inv_scale}"), "f.w"),
        )
    }
}

/// The constant array `name` of normalized centres and weights.
fn constant_array_named(name: &str, centres: &[[f32; 4]], lang: Language) -> String {
    let n = centres.len();
    let ctor = match lang {
        Language::Glsl => "vec4",
        Language::Wgsl => "vec4<f32>",
    };
    let items: Vec<String> = centres
        .iter()
        .map(|c| format!("    {ctor}({}, {}, {}, {})", c[0], c[1], c[2], c[3]))
        .collect();
    let body = items.join(",\n");
    match lang {
        Language::Glsl => {
            format!("const vec4 {name}[{n}] = vec4[{n}](\n{body}\n);\n")
        }
        Language::Wgsl => format!(
            "var<private> {name}: array<vec4<f32>, {n}> = \
             array<vec4<f32>, {n}>(\n{body}\n);\n"
        ),
    }
}

/// The constant integer array `name` (not empty), sixteen numbers a line.
fn int_array(name: &str, values: &[u32], lang: Language) -> String {
    let n = values.len();
    let lines: Vec<String> = values
        .chunks(16)
        .map(|chunk| {
            let items: Vec<String> = chunk.iter().map(u32::to_string).collect();
            format!("    {}", items.join(", "))
        })
        .collect();
    let body = lines.join(",\n");
    match lang {
        Language::Glsl => format!("const int {name}[{n}] = int[{n}](\n{body}\n);\n"),
        Language::Wgsl => {
            format!("var<private> {name}: array<i32, {n}> = array<i32, {n}>(\n{body}\n);\n")
        }
    }
}

/// Each centre normalized (`(c - translate) / scale`, in f64, then rounded to f32) with its
/// weight.
fn normalized_centres(implicit: &Implicit) -> Vec<[f32; 4]> {
    let norm = implicit.normalization();
    let mut q = [0.0; 3];
    implicit
        .constraints()
        .iter()
        .zip(implicit.weights())
        .map(|(c, &w)| {
            norm.apply(c.position(), &mut q);
            [q[0] as f32, q[1] as f32, q[2] as f32, w as f32]
        })
        .collect()
}

/// Refuses a model the shaders cannot hold: one that is not 3D, or has a number beyond f32.
fn check(model: &Model, name: &str) -> Result<()> {
    if model.dim() != 3 {
        return Err(Error::invalid(
            name,
            format!("a {}D model has no function of a 3D point to export", model.dim()),
        ));
    }
    if !numbers_fit(model.shape()) {
        return Err(Error::invalid(
            name,
            "a weight, centre or coefficient is beyond the range of single precision (f32)",
        ));
    }
    Ok(())
}

/// Whether every number the shaders of `shape` hold is finite in f32.
fn numbers_fit(shape: &Shape) -> bool {
    let finite = |x: f64| (x as f32).is_finite();
    match shape {
        Shape::Rbf(f) => implicit_fits(f),
        Shape::Csg(c) => {
            finite(c.blend())
                && c.children()
                    .iter()
                    .all(|child| finite(child.scale()) && numbers_fit(child.shape()))
        }
        Shape::Levels(levels) => {
            implicit_fits(levels.base())
                && levels.levels().iter().all(|level| {
                    finite(level.radius() / levels.base().normalization().scale)
                        && level.weights().iter().all(|&w| finite(w))
                })
        }
    }
}

/// Whether every number of a variational implicit function is finite in f32.
fn implicit_fits(f: &Implicit) -> bool {
    let finite = |x: f64| (x as f32).is_finite();
    let norm = f.normalization();
    normalized_centres(f).iter().flatten().all(|x| x.is_finite())
        && f.polynomial().iter().chain(&norm.translate).all(|&x| finite(x))
        && finite(1.0 / norm.scale)
}

/// A finite number as a float literal both languages read, to f32 precision.
fn number(x: f64) -> String {
    format!("{:?}", x as f32)
}

/// The suffix of a kernel's functions.
fn kernel_name(kernel: Kernel) -> &'static str {
    match kernel {
        Kernel::ThinPlate => "r2logr",
        Kernel::Cubic => "r3",
        Kernel::Linear => "r",
    }
}

/// `implicitize_phi_K(r2)`, the kernel of `r^2`, and `implicitize_dphi_K(r2)`, `phi'(r) / r`.
fn kernel_functions(kernel: &str, lang: Language) -> &'static str {
    match (kernel, lang) {
        ("r2logr", Language::Glsl) => {
            "float implicitize_phi_r2logr(float r2) { return r2 > 0.0 ? 0.5 * r2 * log(r2) : 0.0; }\n\
             float implicitize_dphi_r2logr(float r2) { return r2 > 0.0 ? log(r2) + 1.0 : 0.0; }\n\n"
        }
        ("r2logr", Language::Wgsl) => {
            "fn implicitize_phi_r2logr(r2: f32) -> f32 { return select(0.0, 0.5 * r2 * log(r2), r2 > 0.0); }\n\
             fn implicitize_dphi_r2logr(r2: f32) -> f32 { return select(0.0, log(r2) + 1.0, r2 > 0.0); }\n\n"
        }
        ("r3", Language::Glsl) => {
            "float implicitize_phi_r3(float r2) { return r2 * sqrt(r2); }\n\
             float implicitize_dphi_r3(float r2) { return 3.0 * sqrt(r2); }\n\n"
        }
        ("r3", Language::Wgsl) => {
            "fn implicitize_phi_r3(r2: f32) -> f32 { return r2 * sqrt(r2); }\n\
             fn implicitize_dphi_r3(r2: f32) -> f32 { return 3.0 * sqrt(r2); }\n\n"
        }
        (_, Language::Glsl) => {
            "float implicitize_phi_r(float r2) { return sqrt(r2); }\n\
             float implicitize_dphi_r(float r2) { return r2 > 0.0 ? inversesqrt(r2) : 0.0; }\n\n"
        }
        (_, Language::Wgsl) => {
            "fn implicitize_phi_r(r2: f32) -> f32 { return sqrt(r2); }\n\
             fn implicitize_dphi_r(r2: f32) -> f32 { return select(0.0, inverseSqrt(r2), r2 > 0.0); }\n\n"
        }
    }
}

/// The smooth minimum of [`crate::shape::csg`] and the combination of two children's
/// (gradient, value) by an operation: 0 union, 1 intersection, 2 difference.
fn combine_functions(lang: Language) -> &'static str {
    match lang {
        Language::Glsl => {
            "// Quilez's smooth minimum of radius k and the weight h of a in its gradient.\n\
             vec2 implicitize_smin(float a, float b, float k) {\n\
             \x20   if (k <= 0.0 || abs(a - b) >= k) { return a <= b ? vec2(a, 1.0) : vec2(b, 0.0); }\n\
             \x20   float h = clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);\n\
             \x20   return vec2(h * a + (1.0 - h) * b - k * h * (1.0 - h), h);\n\
             }\n\
             // Union (op 0: max), intersection (1: min) or difference (2: min(a, -b)) of\n\
             // (gradient, value) pairs.\n\
             vec4 implicitize_combine(vec4 a, vec4 b, int op, float k) {\n\
             \x20   vec4 c = op == 2 ? -b : b;\n\
             \x20   float s = op == 0 ? -1.0 : 1.0;\n\
             \x20   vec2 m = implicitize_smin(s * a.w, s * c.w, k);\n\
             \x20   return vec4(m.y * a.xyz + (1.0 - m.y) * c.xyz, s * m.x);\n\
             }\n\n"
        }
        Language::Wgsl => {
            "// Quilez's smooth minimum of radius k and the weight h of a in its gradient.\n\
             fn implicitize_smin(a: f32, b: f32, k: f32) -> vec2<f32> {\n\
             \x20   if (k <= 0.0 || abs(a - b) >= k) { return select(vec2<f32>(b, 0.0), vec2<f32>(a, 1.0), a <= b); }\n\
             \x20   let h = clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);\n\
             \x20   return vec2<f32>(h * a + (1.0 - h) * b - k * h * (1.0 - h), h);\n\
             }\n\
             // Union (op 0: max), intersection (1: min) or difference (2: min(a, -b)) of\n\
             // (gradient, value) pairs.\n\
             fn implicitize_combine(a: vec4<f32>, b: vec4<f32>, op: i32, k: f32) -> vec4<f32> {\n\
             \x20   let c = select(b, -b, op == 2);\n\
             \x20   let s = select(1.0, -1.0, op == 0);\n\
             \x20   let m = implicitize_smin(s * a.w, s * c.w, k);\n\
             \x20   return vec4<f32>(m.y * a.xyz + (1.0 - m.y) * c.xyz, s * m.x);\n\
             }\n\n"
        }
    }
}

/// The comment at the top: what the functions are, the sign convention, units and bounds.
fn header(model: &Model, name: &str, lang: Language, storage: Storage) -> String {
    let b = model.bounds();
    let what = match model.shape() {
        Shape::Rbf(f) => format!(
            "a variational implicit function of {} radial basis functions (kernel {}) plus a \
             linear polynomial",
            f.len(),
            f.kernel()
        ),
        Shape::Csg(c) => format!(
            "a CSG {} of {} shapes (values of each divided by its distance scale: about a \
             signed distance in mesh units near the surface)",
            c.operation(),
            c.children().len()
        ),
        Shape::Levels(levels) => format!(
            "level 0, a variational implicit function of {} radial basis functions (kernel {}) \
             plus a linear polynomial, with {} detail levels of {} compactly supported functions \
             (Wendland's C2) read through grid indexes of their supports",
            levels.base().len(),
            levels.base().kernel(),
            levels.levels().len(),
            levels.centre_count() - levels.base().len()
        ),
    };
    let storage = match storage {
        Storage::Constants => "Its numbers are constants below.",
        Storage::Texture => {
            "Its centres and weights are read from the RGBA32F texture implicitize_centres."
        }
    };
    let language = match lang {
        Language::Glsl => "GLSL (ES 3.00 / 3.30 and later)",
        Language::Wgsl => "WGSL",
    };
    format!(
        "// {name}: {what}.\n\
         // Written by implicitize {} as {language}.\n\
         // implicitize_value(p) is positive inside the shape, negative outside and zero on its\n\
         // surface; implicitize_gradient(p) is its gradient, which points inside.\n\
         // p is a point in the mesh's own units; the shape lies within the bounds\n\
         //   min ({}, {}, {})  max ({}, {}, {}).\n\
         // Evaluated in f32 relative to each function's centre and scale. {storage}\n\n",
        env!("CARGO_PKG_VERSION"),
        b.min.x,
        b.min.y,
        b.min.z,
        b.max.x,
        b.max.y,
        b.max.z,
    )
}
