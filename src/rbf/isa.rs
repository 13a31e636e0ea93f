//! The instruction sets the evaluation loops are compiled for, and the choice among them.
//!
//! The block loops of evaluation exist in three builds: AVX-512 (with a thin-plate loop of
//! its own written with intrinsics), AVX2 with FMA, and the compilation target's baseline.
//! Running a build on a CPU without its features is undefined behaviour, so the choice is an
//! [`Isa`] token that only [`Isa::detect`] and [`Isa::supported`] make, after the CPU reported
//! exactly the features that build enables ([`IsaLevel::features`]).
//!
//! The environment variable `IMPLICITIZE_ISA=baseline|avx2|avx512` forces a build, so that
//! the portable loops can be tested and compared on any machine. [`Isa::from_env`] reads it
//! and refuses a value the CPU cannot run; [`Isa::selected`] is what evaluation uses: the
//! forced build when the variable is valid, the best the CPU runs otherwise (the front door,
//! [`crate::pipeline`], and the command line report an invalid value as an error before
//! anything runs).

use std::sync::OnceLock;

use crate::error::{Error, Result};

/// The environment variable that forces an instruction set.
pub const ENV: &str = "IMPLICITIZE_ISA";

/// An instruction set the loops are compiled for, whether or not this CPU runs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum IsaLevel {
    /// The compilation target's baseline: runs everywhere.
    Baseline,
    /// AVX2 with FMA.
    Avx2,
    /// AVX-512 (F, DQ, VL) with AVX2 and FMA.
    Avx512,
}

impl IsaLevel {
    /// Every level, from the most portable.
    pub const ALL: [IsaLevel; 3] = [IsaLevel::Baseline, IsaLevel::Avx2, IsaLevel::Avx512];

    /// The level's name in `IMPLICITIZE_ISA`: `baseline`, `avx2` or `avx512`.
    pub fn name(self) -> &'static str {
        match self {
            IsaLevel::Baseline => "baseline",
            IsaLevel::Avx2 => "avx2",
            IsaLevel::Avx512 => "avx512",
        }
    }

    /// The level named `name`.
    pub fn from_name(name: &str) -> Option<IsaLevel> {
        IsaLevel::ALL.into_iter().find(|l| l.name() == name)
    }

    /// The CPU features the level's loops are compiled with (their `target_feature`s).
    pub fn features(self) -> &'static [&'static str] {
        match self {
            IsaLevel::Baseline => &[],
            IsaLevel::Avx2 => &["avx2", "fma"],
            IsaLevel::Avx512 => &["avx512f", "avx512dq", "avx512vl", "avx2", "fma"],
        }
    }
}

/// An instruction set this CPU runs. Only [`Isa::detect`], [`Isa::supported`] and
/// [`Isa::selected`] make one, after checking every feature of its level, so code compiled
/// for it may run wherever an `Isa` of its level is at hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Isa {
    level: IsaLevel,
}

impl Isa {
    /// The best instruction set this CPU runs.
    pub fn detect() -> Isa {
        let mut levels = IsaLevel::ALL.into_iter().rev();
        levels.find_map(Isa::supported).unwrap_or(Isa { level: IsaLevel::Baseline })
    }

    /// `level`, if this CPU has every feature its loops are compiled with.
    pub fn supported(level: IsaLevel) -> Option<Isa> {
        level.features().iter().all(|f| has_feature(f)).then_some(Isa { level })
    }

    /// The level of this instruction set.
    pub fn level(self) -> IsaLevel {
        self.level
    }

    /// The instruction set `IMPLICITIZE_ISA` forces, `None` when it is not set.
    ///
    /// # Errors
    /// A value other than `baseline`, `avx2` and `avx512`, or a level this CPU cannot run.
    pub fn from_env() -> Result<Option<Isa>> {
        match std::env::var(ENV) {
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(_)) => {
                Err(Error::invalid(ENV, "expected baseline, avx2 or avx512"))
            }
            Ok(value) => Isa::named(&value).map(Some),
        }
    }

    /// The instruction set named `value`, if this CPU runs it.
    fn named(value: &str) -> Result<Isa> {
        let context = format!("{ENV}={value}");
        let level = IsaLevel::from_name(value)
            .ok_or_else(|| Error::invalid(&context, "expected baseline, avx2 or avx512"))?;
        Isa::supported(level).ok_or_else(|| {
            let runs: Vec<&str> = IsaLevel::ALL
                .into_iter()
                .filter(|&l| Isa::supported(l).is_some())
                .map(IsaLevel::name)
                .collect();
            Error::invalid(
                &context,
                format!(
                    "this CPU lacks {} ({}); it runs {}",
                    level.name(),
                    level.features().join(", "),
                    runs.join(", ")
                ),
            )
        })
    }

    /// What evaluation uses: the instruction set `IMPLICITIZE_ISA` forces when it is valid,
    /// else the best this CPU runs. Read once per process.
    pub fn selected() -> Isa {
        static SELECTED: OnceLock<Isa> = OnceLock::new();
        *SELECTED.get_or_init(|| Isa::from_env().ok().flatten().unwrap_or_else(Isa::detect))
    }
}

/// Whether this CPU has `feature` (one of those in [`IsaLevel::features`]).
fn has_feature(feature: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        match feature {
            "avx512f" => std::is_x86_feature_detected!("avx512f"),
            "avx512dq" => std::is_x86_feature_detected!("avx512dq"),
            "avx512vl" => std::is_x86_feature_detected!("avx512vl"),
            "avx2" => std::is_x86_feature_detected!("avx2"),
            "fma" => std::is_x86_feature_detected!("fma"),
            _ => false,
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = feature;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_baseline_is_always_supported_and_detection_picks_a_supported_level() {
        assert_eq!(Isa::supported(IsaLevel::Baseline).map(Isa::level), Some(IsaLevel::Baseline));
        let best = Isa::detect().level();
        assert!(Isa::supported(best).is_some());
        assert!(
            IsaLevel::ALL.into_iter().filter(|&l| l > best).all(|l| Isa::supported(l).is_none())
        );
    }

    /// A level forced by `IMPLICITIZE_ISA` is the one evaluation runs: a run meant to test a
    /// level the CPU lacks (CI runs the numeric tests at every level the CPU supports) fails
    /// here instead of silently testing the best level.
    #[test]
    fn a_forced_level_is_the_one_selected() {
        if let Ok(name) = std::env::var(ENV) {
            assert_eq!(Isa::selected().level().name(), name, "{ENV}={name} is not what runs");
        }
    }

    #[test]
    fn names_round_trip_and_bad_values_are_one_line_errors() {
        for level in IsaLevel::ALL {
            assert_eq!(IsaLevel::from_name(level.name()), Some(level));
        }
        let e = Isa::named("sse9").unwrap_err().to_string();
        assert!(e.starts_with("IMPLICITIZE_ISA=sse9: expected baseline") && !e.contains('\n'));
        if let Some(lacking) = IsaLevel::ALL.into_iter().find(|&l| Isa::supported(l).is_none()) {
            let e = Isa::named(lacking.name()).unwrap_err().to_string();
            assert!(e.contains("this CPU lacks") && e.contains(lacking.features()[0]), "{e}");
        }
    }
}
