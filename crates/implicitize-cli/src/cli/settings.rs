//! The fit's settings as flags, made from the library's table
//! (`implicitize::pipeline::settings::FitSettings::table`): each setting's flag, value, help and default come
//! from there, and the values given are read into `FitSettings` by name, so that a setting
//! added to the library is a flag of `fit`, `demo` and `batch` without a line here.

use clap::error::ErrorKind;
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use implicitize::pipeline::settings::{FitSettings, Kind, Setting};
use serde_json::{Map, Value};

/// The fit's settings as the command line gave them.
#[derive(Debug, Clone, Default)]
pub struct SettingsArgs {
    /// The settings given (on the command line, or a default a command sets of its own).
    pub settings: FitSettings,
    /// The names of those given on the command line, which a settings file does not replace.
    pub given: Vec<String>,
}

/// The flag of `setting`.
fn flag(setting: &Setting) -> Arg {
    let arg = Arg::new(setting.name)
        .long(setting.name.replace('_', "-"))
        .help(help(setting, setting.default.as_deref()));
    let arg = match setting.kind {
        Kind::Switch => arg.action(ArgAction::SetTrue),
        Kind::Count => arg.value_parser(clap::value_parser!(u64)).value_name(setting.value_name),
        Kind::Number => arg
            .value_parser(clap::value_parser!(f64))
            .allow_negative_numbers(true)
            .value_name(setting.value_name),
        Kind::Counts3 => arg
            .value_parser(clap::value_parser!(u64))
            .num_args(3)
            .value_names(setting.value_name.split(' ')),
        Kind::Choice(words) => arg
            .value_parser(clap::builder::PossibleValuesParser::new(words))
            .value_name(setting.value_name),
        Kind::Text => arg.value_name(setting.value_name),
    };
    match setting.excludes {
        Some(other) => arg.conflicts_with(other),
        None => arg,
    }
}

/// The help of `setting`, with `default` shown.
fn help(setting: &Setting, default: Option<&str>) -> String {
    match default {
        Some(default) => format!("{} [default: {default}]", setting.help),
        None => setting.help.to_string(),
    }
}

/// `arg` (the flag of the setting `name`) with a default of a command's own, shown and taken
/// when the command line gives none.
pub fn own_default(arg: Arg, name: &str, default: &'static str) -> Arg {
    let setting = FitSettings::table().into_iter().find(|s| s.name == name).expect("a setting");
    arg.help(help(&setting, Some(default))).default_value(default).hide_default_value(true)
}

/// The value of `setting` in `matches`, as the library reads it.
fn value(setting: &Setting, matches: &ArgMatches) -> Result<Value, clap::Error> {
    let name = setting.name;
    let one = |value: Option<&String>| Value::from(value.cloned());
    Ok(match setting.kind {
        Kind::Switch => Value::Bool(matches.get_flag(name)),
        Kind::Count => Value::from(matches.get_one::<u64>(name).copied()),
        Kind::Number => match matches.get_one::<f64>(name) {
            Some(&x) => serde_json::Number::from_f64(x).map(Value::Number).ok_or_else(|| {
                clap::Error::raw(
                    ErrorKind::ValueValidation,
                    format!("{} must be a finite number, not {x}\n", setting.name),
                )
            })?,
            None => Value::Null,
        },
        Kind::Counts3 => Value::from(
            matches.get_many::<u64>(name).map(|values| values.copied().collect::<Vec<_>>()),
        ),
        Kind::Choice(_) | Kind::Text => one(matches.get_one::<String>(name)),
    })
}

impl FromArgMatches for SettingsArgs {
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        let (mut values, mut given) = (Map::new(), Vec::new());
        for setting in FitSettings::table() {
            match matches.value_source(setting.name) {
                Some(ValueSource::CommandLine) => given.push(setting.name.to_string()),
                // A default of a command's own (`own_default`); switches are off by default.
                Some(ValueSource::DefaultValue) if setting.kind != Kind::Switch => {}
                _ => continue,
            }
            values.insert(setting.name.to_string(), value(&setting, matches)?);
        }
        let settings = FitSettings::from_values(values, "options")
            .map_err(|e| clap::Error::raw(ErrorKind::ValueValidation, format!("{e}\n")))?;
        Ok(SettingsArgs { settings, given })
    }

    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        *self = SettingsArgs::from_arg_matches(matches)?;
        Ok(())
    }
}

impl Args for SettingsArgs {
    fn augment_args(command: Command) -> Command {
        FitSettings::table().iter().fold(command, |command, setting| command.arg(flag(setting)))
    }

    fn augment_args_for_update(command: Command) -> Command {
        SettingsArgs::augment_args(command)
    }
}
