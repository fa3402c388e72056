//! Presets and user configuration files.
//!
//! A preset is a TOML file in `presets/` (compiled into the binary so `joca` works from any
//! directory); a user's `--config FILE` is merged over it table by table, so it only needs the
//! fields it changes. Unknown fields are refused, naming the field and the file.

use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use std::path::Path;

/// The largest motion-blur multiplier a command accepts: 25× the paper's strongest scenario (×4).
pub const MAX_BLUR_SCALE: f64 = 100.0;

/// A command-line count in `LO..=HI` (clap value parser): anything else is refused naming the
/// allowed range, before anything runs.
pub fn count<const LO: usize, const HI: usize>(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if (LO..=HI).contains(&n) => Ok(n),
        _ => Err(format!("{text:?} is not a whole number from {LO} to {HI}")),
    }
}

/// A command-line device (clap value parser): `cpu`, `cuda`, `cuda:N` or `auto`; anything else
/// is refused naming the allowed values. Whether the machine has it is checked when the
/// command opens its engine.
pub fn device(text: &str) -> Result<joca_nn::device::DeviceChoice, String> {
    text.parse().map_err(|e: joca_nn::NnError| e.to_string())
}

/// The presets shipped with joca, by name.
pub const PRESETS: [(&str, &str); 3] = [
    ("quick", include_str!("../../../presets/quick.toml")),
    ("standard", include_str!("../../../presets/standard.toml")),
    ("paper", include_str!("../../../presets/paper.toml")),
];

/// The preset's TOML text, or an error listing the valid names.
pub fn preset(name: &str) -> Result<&'static str> {
    match PRESETS.iter().find(|(n, _)| *n == name) {
        Some((_, text)) => Ok(text),
        None => bail!(
            "unknown preset {name:?}; valid: {}",
            PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// The top-level tables a configuration file may hold.
const TABLES: [&str; 2] = ["run", "pretrain"];

fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// Preset `name` with `user_file` merged over it, and a description of that source for errors.
pub fn load_table(name: &str, user_file: Option<&Path>) -> Result<(toml::Table, String)> {
    load_table_with(name, user_file, &[])
}

/// [`load_table`] for a command that also reads the top-level tables `extra` of the user's file
/// (`joca headroom`'s `[ladder]`).
pub fn load_table_with(
    name: &str,
    user_file: Option<&Path>,
    extra: &[&str],
) -> Result<(toml::Table, String)> {
    let mut table: toml::Table =
        toml::from_str(preset(name)?).with_context(|| format!("preset {name} is invalid"))?;
    let mut source = format!("preset {name}");
    if let Some(path) = user_file {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read config file {}", path.display()))?;
        let user: toml::Table = toml::from_str(&text)
            .with_context(|| format!("invalid config file {}", path.display()))?;
        // Within a table serde refuses unknown fields; a misspelt table would go unread.
        let allowed: Vec<&str> = TABLES.iter().chain(extra).copied().collect();
        if let Some(unknown) = user.keys().find(|k| !allowed.contains(&k.as_str())) {
            bail!(
                "config file {}: unknown table or field `{unknown}` at the top level; allowed: \
                 [{}]",
                path.display(),
                allowed.join("], [")
            );
        }
        merge(&mut table, user);
        source = format!("{} over preset {name}", path.display());
    }
    Ok((table, source))
}

/// Merges `over` into `base`, table by table (a value in `over` replaces the one in `base`).
pub fn merge_tables(base: &mut toml::Table, over: toml::Table) {
    merge(base, over);
}

/// Table `section` of preset `name` with `user_file` merged over it, as `T`.
pub fn load<T: DeserializeOwned>(name: &str, user_file: Option<&Path>, section: &str) -> Result<T> {
    load_with_source(name, user_file, section).map(|(value, _)| value)
}

/// [`load`], with the description of the source ([`load_table`]'s) for later errors.
pub fn load_with_source<T: DeserializeOwned>(
    name: &str,
    user_file: Option<&Path>,
    section: &str,
) -> Result<(T, String)> {
    let (mut table, source) = load_table(name, user_file)?;
    let value =
        table.remove(section).with_context(|| format!("{source} has no [{section}] table"))?;
    let value = value.try_into().with_context(|| format!("invalid [{section}] in {source}"))?;
    Ok((value, source))
}
