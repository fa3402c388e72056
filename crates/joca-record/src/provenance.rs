//! Where a record came from: joca's version, the git commit it was built from (and whether
//! the working tree differed from that commit), and a digest of the configuration as the run
//! read it — MLflow's git tag and DVC's run-cache key in one field of every record, so that a
//! table can refuse to mix cells that different code or configurations computed.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// The provenance of one record (`provenance` in `results.json`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// joca's package version.
    pub joca_version: String,
    /// The git commit the binary was built from (`unknown` outside a git checkout).
    pub commit: String,
    /// Whether tracked files differed from `commit` when the binary was built (`None`:
    /// unknown).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dirty: Option<bool>,
    /// SHA-256 (hex) of the configuration as read, serialised as canonical JSON (fields in
    /// declaration order, so the order of a TOML file does not change it).
    pub config_sha256: String,
}

impl Provenance {
    /// This binary's provenance for a record computed from `config` (any serialisable value;
    /// pass what identifies the computation: a run's `RunConfig::identity`).
    pub fn of_this_build(config: &impl Serialize) -> Self {
        Self {
            joca_version: env!("CARGO_PKG_VERSION").to_owned(),
            commit: BUILD_COMMIT.to_owned(),
            dirty: build_dirty(),
            config_sha256: config_sha256(config),
        }
    }

    /// Whether this binary was built from the same commit, equally clean: a record it would
    /// compute again the same way from the same configuration.
    pub fn is_this_build(&self) -> bool {
        self.commit == BUILD_COMMIT && self.dirty == build_dirty()
    }

    /// The commit with a `-dirty` suffix where the tree differed, as tables print it.
    pub fn commit_label(&self) -> String {
        let short: String = self.commit.chars().take(10).collect();
        match self.dirty {
            Some(true) => format!("{short}-dirty"),
            Some(false) => short,
            None => format!("{short}?"),
        }
    }
}

/// The commit this binary was built from.
pub const BUILD_COMMIT: &str = env!("JOCA_GIT_COMMIT");

fn build_dirty() -> Option<bool> {
    match env!("JOCA_GIT_DIRTY") {
        "true" => Some(true),
        "false" => Some(false),
        _ => None,
    }
}

/// SHA-256 (lower-case hex) of `value`'s JSON serialisation.
pub fn config_sha256(value: &impl Serialize) -> String {
    let json = serde_json::to_string(value).unwrap_or_default();
    let digest = Sha256::digest(json.as_bytes());
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Config {
        seed: u64,
        name: &'static str,
    }

    #[test]
    fn digest_is_sha256_of_the_json() {
        // `printf '{"seed":1,"name":"a"}' | sha256sum`
        let expected = "79d5a90fc0e9091ee99850abc5884f8726f5bdf51c9bd755c41d63c590bd154e";
        assert_eq!(config_sha256(&Config { seed: 1, name: "a" }), expected);
    }

    #[test]
    fn a_changed_field_changes_the_digest() {
        let a = config_sha256(&Config { seed: 1, name: "a" });
        assert_ne!(a, config_sha256(&Config { seed: 2, name: "a" }));
        assert_ne!(a, config_sha256(&Config { seed: 1, name: "b" }));
        assert_eq!(a, config_sha256(&Config { seed: 1, name: "a" }));
    }
}
