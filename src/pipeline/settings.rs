//! The settings a user gives a fit, by the names they give them, written once.
//!
//! [`FitSettings`] holds every setting of `implicitize fit` (and `demo`, `batch`, Python's
//! `implicitize.fit`, `python -m implicitize.batch`) by its user-facing name: `snake_case` as
//! Python's keywords and settings files spell it, `--kebab-case` on the command line. Each
//! is `None` (or `false`) where the user gave nothing, and [`FitSettings::options`] is the one
//! conversion into the library's [`MeshFitOptions`]: the defaults, the ranges and their
//! errors live there, not in each front end.
//!
//! [`FitSettings::table`] describes each setting (its name, unit, default and one line of help) for
//! the front ends and the docs; tests hold the command line's flags, the Python signatures
//! and stubs and the batch front ends against it, so that a setting added here and missed
//! there fails a test.
//!
//! A settings file is the same struct read from TOML or JSON ([`FitSettings::read`]): an
//! unknown key is an error naming the key and the file.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{MeshFitOptions, Method};
use crate::error::{Error, Result};
use crate::fit::{ErrorMeasure, FitOptions, LevelOptions, MAX_CONSTRAINTS};
use crate::grid::Resolution;
use crate::memory::MemoryLimit;

/// A fit's settings as the user gives them; `None` or `false`: the library's default (see
/// [`FitSettings::table`] for each one's meaning, unit and default).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct FitSettings {
    /// Voxels along the mesh's longest axis.
    pub resolution: Option<usize>,
    /// An exact grid size instead of `resolution`.
    pub dims: Option<[usize; 3]>,
    /// Stop once E is at most this many voxels.
    pub target_error: Option<f64>,
    /// The seed of every random choice.
    pub seed: Option<u64>,
    /// Never more constraints than this.
    pub max_constraints: Option<usize>,
    /// `iterative` (paper 5) or `naive` (paper 3.2).
    pub method: Option<String>,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// Measure E from points on the surfaces.
    pub subvoxel: bool,
    /// No start at half the resolution.
    pub full_resolution: bool,
    /// At most this many detail levels.
    pub levels: Option<usize>,
    /// Fit the surface thickened to this: voxels (`2`), or mesh units (`0.01u`); a number
    /// read is taken as its text.
    #[serde(deserialize_with = "text_or_number")]
    pub shell: Option<String>,
    /// Fit the guessed solid of a mesh open over much of the grid.
    pub solid: bool,
    /// The most accurate model within this many bytes of binary model file.
    pub max_bytes: Option<u64>,
}

/// What a setting is, for the front ends and the docs: each front end makes its flag or
/// keyword from this, and reads a value as its [`Kind`] says into [`FitSettings`] through
/// serde, by name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setting {
    /// Its name: a Python keyword and settings-file key; `--` and the name with `-` for `_`
    /// is its command-line flag.
    pub name: &'static str,
    /// The values it takes.
    pub kind: Kind,
    /// The placeholder of its value in usage lines (`N`, `T`, `VOXELS`); empty for a flag.
    pub value_name: &'static str,
    /// The unit or kind of its value, in words.
    pub unit: &'static str,
    /// Its default as text, or `None` where giving nothing means something else (a flag off,
    /// a choice the fit makes).
    pub default: Option<String>,
    /// The setting that may not be given with it (`resolution` and `dims`, `shell` and
    /// `solid`).
    pub excludes: Option<&'static str>,
    /// Its help: what it does, in a sentence or two.
    pub help: String,
}

/// The values a setting takes, as the front ends parse them before [`FitSettings`] checks
/// their ranges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A whole number of 0 or more.
    Count,
    /// A number.
    Number,
    /// Three whole numbers of 0 or more.
    Counts3,
    /// On or off: a flag on the command line, `true` or `false` elsewhere.
    Switch,
    /// One of these words.
    Choice(&'static [&'static str]),
    /// Text; a number is taken as its text.
    Text,
}

impl Setting {
    /// The command-line flag: `--max-iterations` for `max_iterations`.
    pub fn flag(&self) -> String {
        format!("--{}", self.name.replace('_', "-"))
    }
}

/// A setting of text, given as text or as a number (a shell of `2` voxels: `"2"`).
fn text_or_number<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<String>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Given {
        Text(String),
        Whole(i64),
        Number(f64),
    }
    Ok(Option::<Given>::deserialize(d)?.map(|given| match given {
        Given::Text(text) => text,
        Given::Whole(n) => n.to_string(),
        Given::Number(x) => x.to_string(),
    }))
}

impl Kind {
    /// Whether `value` is of this kind (a number for text too: a shell of `2` voxels).
    fn accepts(self, value: &serde_json::Value) -> bool {
        use serde_json::Value;
        match (self, value) {
            (Kind::Count, Value::Number(n)) => n.is_u64(),
            (Kind::Number, Value::Number(_)) => true,
            (Kind::Counts3, Value::Array(items)) => {
                items.len() == 3 && items.iter().all(|v| v.as_u64().is_some())
            }
            (Kind::Switch, Value::Bool(_)) => true,
            (Kind::Choice(words), Value::String(word)) => words.contains(&word.as_str()),
            (Kind::Text, Value::String(_) | Value::Number(_)) => true,
            _ => false,
        }
    }

    /// What values of this kind are, in words.
    pub fn words(self) -> String {
        match self {
            Kind::Count => "a whole number of 0 or more".into(),
            Kind::Number => "a number".into(),
            Kind::Counts3 => "three whole numbers of 0 or more".into(),
            Kind::Switch => "true or false".into(),
            Kind::Choice(words) => {
                let quoted: Vec<String> = words.iter().map(|w| format!("{w:?}")).collect();
                format!("one of {}", quoted.join(", "))
            }
            Kind::Text => "text or a number".into(),
        }
    }
}

impl FitSettings {
    /// Every setting, in the order the front ends list them.
    pub fn table() -> Vec<Setting> {
        let fit = FitOptions::default();
        let text = |value: &dyn std::fmt::Display| Some(value.to_string());
        vec![
            Setting {
                name: "resolution",
                kind: Kind::Count,
                value_name: "N",
                unit: "voxels",
                default: text(&Resolution::DEFAULT_LONGEST_AXIS),
                excludes: Some("dims"),
                help: "Voxels along the mesh's longest axis, margins included (the paper's \
                       volumes: bunny 220, horse 337, triceratops 320)"
                    .into(),
            },
            Setting {
                name: "dims",
                kind: Kind::Counts3,
                value_name: "NX NY NZ",
                unit: "voxels, three",
                default: None,
                excludes: Some("resolution"),
                help: "An exact grid size instead of resolution".into(),
            },
            Setting {
                name: "target_error",
                kind: Kind::Number,
                value_name: "VOXELS",
                unit: "voxels",
                default: text(&fit.target_error),
                excludes: None,
                help: "Stop once the max error E is at most this many voxels; errors above it are \
                       corrected however flat the surface is there"
                    .into(),
            },
            Setting {
                name: "seed",
                kind: Kind::Count,
                value_name: "SEED",
                unit: "integer",
                default: text(&fit.seed),
                excludes: None,
                help: "Seed of every random choice, such as the initial constraints (same seed, \
                       same model)"
                    .into(),
            },
            Setting {
                name: "max_constraints",
                kind: Kind::Count,
                value_name: "N",
                unit: "count",
                default: text(&MAX_CONSTRAINTS),
                excludes: None,
                help: format!(
                    "Never use more constraints than this (the naive method: {}, half of them mesh \
                     vertices)",
                    Method::Naive.default_max_constraints()
                ),
            },
            Setting {
                name: "method",
                kind: Kind::Choice(&["iterative", "naive"]),
                value_name: "METHOD",
                unit: "iterative or naive",
                default: text(&"iterative"),
                excludes: None,
                help: "How the constraints are made: the paper's iterative method (section 5), or \
                       its simple method (section 3.2), mesh vertices and normal offsets"
                    .into(),
            },
            Setting {
                name: "max_iterations",
                kind: Kind::Count,
                value_name: "N",
                unit: "count",
                default: text(&fit.max_iterations),
                excludes: None,
                help: "Stop after this many iterations".into(),
            },
            Setting {
                name: "subvoxel",
                kind: Kind::Switch,
                value_name: "",
                unit: "flag",
                default: None,
                excludes: None,
                help: "Measure E from points on the surfaces rather than from voxel centres: the \
                       measure for targets of a voxel or less (a voxel-centre E is never below 0.5 \
                       and moves in steps)"
                    .into(),
            },
            Setting {
                name: "full_resolution",
                kind: Kind::Switch,
                value_name: "",
                unit: "flag",
                default: None,
                excludes: None,
                help: "Run every iteration on the full grid: no start at half the resolution \
                       (which the fit makes on grids of 128 voxels or more)"
                    .into(),
            },
            Setting {
                name: "levels",
                kind: Kind::Count,
                value_name: "N",
                unit: "count",
                default: text(&LevelOptions::default().max_levels),
                excludes: None,
                help: "At most this many detail levels: on grids of 384 voxels or more, level 0 \
                       is fitted at a quarter of the resolution and levels of compactly supported \
                       functions are added until E is at most the target; 0 fits one function as \
                       the paper does"
                    .into(),
            },
            Setting {
                name: "shell",
                kind: Kind::Text,
                value_name: "T",
                unit: "voxels, or mesh units with the suffix u",
                default: None,
                excludes: Some("solid"),
                help:
                    "Fit the mesh's surface thickened to T in all (half on each side) instead of \
                       its solid, for open shells and walls too thin for the grid: voxels (2) or \
                       mesh units (0.01u)"
                        .into(),
            },
            Setting {
                name: "solid",
                kind: Kind::Switch,
                value_name: "",
                unit: "flag",
                default: None,
                excludes: Some("shell"),
                help: "Fit the solid an open mesh's winding numbers guess even where much of the \
                       grid is a guess (more than a fifth of it near one half), which is refused \
                       otherwise"
                    .into(),
            },
            Setting {
                name: "max_bytes",
                kind: Kind::Count,
                value_name: "N",
                unit: "bytes",
                default: None,
                excludes: None,
                help: "Make the most accurate model whose binary file has at most N bytes, \
                       choosing the resolution, target and detail levels; a budget below the \
                       smallest model is refused, naming its size"
                    .into(),
            },
        ]
    }

    /// The settings from values by setting name (JSON: numbers, booleans, text, lists), as a
    /// front end read them by each setting's [`Kind`]; a null is a setting not given.
    ///
    /// # Errors
    /// A name that is no setting, or a value of the wrong kind, named (`context` names where the
    /// values came from).
    pub fn from_values(
        values: serde_json::Map<String, serde_json::Value>,
        context: &str,
    ) -> Result<FitSettings> {
        let table = FitSettings::table();
        for (name, value) in &values {
            let Some(setting) = table.iter().find(|s| s.name == name) else {
                return Err(Error::invalid(context, format!("`{name}` is not a fit setting")));
            };
            if !value.is_null() && !setting.kind.accepts(value) {
                return Err(Error::invalid(
                    context,
                    format!("`{name}` takes {}, not {value}", setting.kind.words()),
                ));
            }
        }
        let values: serde_json::Map<_, _> =
            values.into_iter().filter(|(_, v)| !v.is_null()).collect();
        serde_json::from_value(serde_json::Value::Object(values))
            .map_err(|e| Error::invalid(context, format!("not a fit's settings: {e}")))
    }

    /// The library's options: its defaults with what was given set on them, checked, under
    /// `memory_limit`.
    ///
    /// # Errors
    /// A setting out of its range, named (`context` names where the settings came from: the
    /// options, or a settings file).
    pub fn options(&self, context: &str, memory_limit: MemoryLimit) -> Result<MeshFitOptions> {
        let positive = |name: &str, n: usize| {
            if n == 0 {
                Err(Error::invalid(context, format!("`{name}` must be at least 1, not 0")))
            } else {
                Ok(n)
            }
        };
        let resolution = match (self.dims, self.resolution) {
            (Some(_), Some(_)) => {
                return Err(Error::invalid(context, "give `resolution` or `dims`, not both"));
            }
            (Some(dims), None) => Resolution::Dims(dims),
            (None, Some(n)) => Resolution::LongestAxis(n),
            (None, None) => Resolution::default(),
        };
        if self.shell.is_some() && self.solid {
            return Err(Error::invalid(context, "give `shell` or `solid`, not both"));
        }
        let mut options = MeshFitOptions { resolution, ..MeshFitOptions::default() };
        if let Some(method) = &self.method {
            options.method = method.parse::<Method>().map_err(|e| e.in_context(context))?;
        }
        let fit = &mut options.fit;
        if let Some(target) = self.target_error {
            fit.target_error = target as f32;
        }
        if let Some(seed) = self.seed {
            fit.seed = seed;
        }
        if let Some(n) = self.max_iterations {
            fit.max_iterations = positive("max_iterations", n)?;
        }
        if let Some(n) = self.max_constraints {
            fit.max_constraints = Some(positive("max_constraints", n)?);
        }
        if self.subvoxel {
            fit.error_measure = ErrorMeasure::SubVoxel;
        }
        fit.coarse_start = !self.full_resolution;
        if let Some(n) = self.levels {
            fit.levels.max_levels = n;
        }
        options.shell = self
            .shell
            .as_deref()
            .map(str::parse)
            .transpose()
            .map_err(|e: Error| e.in_context(context))?;
        options.solid = self.solid;
        if let Some(n) = self.max_bytes {
            if n == 0 {
                return Err(Error::invalid(context, "`max_bytes` must be at least 1, not 0"));
            }
            options.max_bytes = Some(n);
        }
        options.memory_limit = memory_limit;
        options.check().map_err(|e| e.in_context(context))?;
        Ok(options)
    }

    /// The settings of the file at `path`: TOML, or JSON for a name ending in `.json`.
    ///
    /// # Errors
    /// A file that cannot be read or parsed, holds a key that is not a setting or a value out
    /// of its range (the error names the key and the file).
    pub fn read(path: &Path) -> Result<FitSettings> {
        let source = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(&source, e))?;
        let json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let parsed = if json {
            serde_json::from_str(&text).map_err(|e| e.to_string())
        } else {
            toml::from_str(&text).map_err(|e: toml::de::Error| {
                let line = e.span().map_or(1, |span| text[..span.start].matches('\n').count() + 1);
                format!("line {line}: {}", e.message())
            })
        };
        // The file's keys as the file spells them, not as a front end words a setting.
        let why = |why: String| why.replace('`', "\"");
        let settings: FitSettings = parsed
            .map_err(|e| Error::invalid(&source, format!("not a fit's settings: {}", why(e))))?;
        match settings.options("options", MemoryLimit::default()) {
            Err(Error::Invalid { message, .. }) => Err(Error::invalid(&source, why(message))),
            Err(other) => Err(other),
            Ok(_) => Ok(settings),
        }
    }
}
