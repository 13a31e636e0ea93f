//! The settings a user gives a fit, by the names they give them, written once.
//!
//! [`FitSettings`] holds every setting of `implicitize fit` (and `demo`, `batch`, Python's
//! `implicitize.fit`, `python -m implicitize.batch`) by its user-facing name: `snake_case` as
//! Python's keywords and settings files spell it, `--kebab-case` on the command line. Each
//! is `None` (or `false`) where the user gave nothing, and [`FitSettings::options`] is the one
//! conversion into the library's [`MeshFitOptions`]: the defaults, the ranges and their
//! errors live there, not in each front end.
//!
//! [`fit_settings`] describes each setting (its name, unit, default and one line of help) for
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
/// [`fit_settings`] for each one's meaning, unit and default).
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
    /// Fit the surface thickened to this: voxels (`2`), or mesh units (`0.01u`).
    pub shell: Option<String>,
    /// Fit the guessed solid of a mesh open over much of the grid.
    pub solid: bool,
    /// The most accurate model within this many bytes of binary model file.
    pub max_bytes: Option<u64>,
}

/// What a setting is, for the front ends and the docs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setting {
    /// Its name: a Python keyword and settings-file key; `--` and the name with `-` for `_`
    /// is its command-line flag.
    pub name: &'static str,
    /// The unit or kind of its value.
    pub unit: &'static str,
    /// Its default as text, or `None` where giving nothing means something else (a flag off,
    /// a choice the fit makes).
    pub default: Option<String>,
    /// One line of help.
    pub help: &'static str,
}

impl Setting {
    /// The command-line flag: `--max-iterations` for `max_iterations`.
    pub fn flag(&self) -> String {
        format!("--{}", self.name.replace('_', "-"))
    }
}

/// Every setting of [`FitSettings`], in the order the front ends list them.
pub fn fit_settings() -> Vec<Setting> {
    let fit = FitOptions::default();
    let text = |value: &dyn std::fmt::Display| Some(value.to_string());
    vec![
        Setting {
            name: "resolution",
            unit: "voxels",
            default: text(&Resolution::DEFAULT_LONGEST_AXIS),
            help: "voxels along the mesh's longest axis, margins included",
        },
        Setting {
            name: "dims",
            unit: "voxels, three",
            default: None,
            help: "an exact grid size instead of resolution",
        },
        Setting {
            name: "target_error",
            unit: "voxels",
            default: text(&fit.target_error),
            help: "stop once the max error E is at most this",
        },
        Setting {
            name: "seed",
            unit: "integer",
            default: text(&fit.seed),
            help: "seed of every random choice (same seed, same model)",
        },
        Setting {
            name: "max_constraints",
            unit: "count",
            default: text(&MAX_CONSTRAINTS),
            help: "never more constraints than this (naive: its own default)",
        },
        Setting {
            name: "method",
            unit: "iterative | naive",
            default: text(&"iterative"),
            help: "how constraints are made: paper 5, or paper 3.2",
        },
        Setting {
            name: "max_iterations",
            unit: "count",
            default: text(&fit.max_iterations),
            help: "stop after this many iterations",
        },
        Setting {
            name: "subvoxel",
            unit: "flag",
            default: None,
            help: "measure E from points on the surfaces, not voxel centres",
        },
        Setting {
            name: "full_resolution",
            unit: "flag",
            default: None,
            help: "every iteration on the full grid: no start at half the resolution",
        },
        Setting {
            name: "levels",
            unit: "count",
            default: text(&LevelOptions::default().max_levels),
            help: "at most this many detail levels on large grids (0: one function)",
        },
        Setting {
            name: "shell",
            unit: "voxels, or mesh units with the suffix u",
            default: None,
            help: "fit the surface thickened to this instead of its solid",
        },
        Setting {
            name: "solid",
            unit: "flag",
            default: None,
            help: "fit the guessed solid of a mesh open over much of the grid",
        },
        Setting {
            name: "max_bytes",
            unit: "bytes",
            default: None,
            help: "the most accurate model whose binary file has at most this many bytes",
        },
    ]
}

impl FitSettings {
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
