//! Atomic checkpoint directories: a checkpoint is written completely into `<name>.partial/` and
//! then swapped in with renames, so a run killed at any instant leaves either the previous
//! checkpoint or the new one, never a mixture.

use crate::TrainError;
use std::path::{Path, PathBuf};

/// Where the checkpoint of `dir` lives and its temporaries.
#[derive(Debug, Clone)]
pub struct CheckpointDir {
    path: PathBuf,
}

impl CheckpointDir {
    /// The checkpoint at `path` (e.g. `runs/x/checkpoint`).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    fn partial(&self) -> PathBuf {
        self.path.with_extension("partial")
    }

    fn old(&self) -> PathBuf {
        self.path.with_extension("old")
    }

    /// The directory to read from, if a complete checkpoint exists (recovering one left by a
    /// crash between the two renames of [`CheckpointDir::write`]).
    pub fn existing(&self) -> Option<PathBuf> {
        if self.path.is_dir() {
            Some(self.path.clone())
        } else if self.old().is_dir() {
            Some(self.old())
        } else {
            None
        }
    }

    /// Writes a new checkpoint: `fill` writes the files into a fresh temporary directory, which
    /// then replaces the current checkpoint.
    pub fn write(
        &self,
        fill: impl FnOnce(&Path) -> Result<(), TrainError>,
    ) -> Result<(), TrainError> {
        let partial = self.partial();
        if partial.exists() {
            std::fs::remove_dir_all(&partial).map_err(|e| TrainError::io(&partial, e))?;
        }
        std::fs::create_dir_all(&partial).map_err(|e| TrainError::io(&partial, e))?;
        fill(&partial)?;
        write_digests(&partial)?;
        let old = self.old();
        if self.path.exists() {
            if old.exists() {
                std::fs::remove_dir_all(&old).map_err(|e| TrainError::io(&old, e))?;
            }
            std::fs::rename(&self.path, &old).map_err(|e| TrainError::io(&self.path, e))?;
        }
        std::fs::rename(&partial, &self.path).map_err(|e| TrainError::io(&partial, e))?;
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(|e| TrainError::io(&old, e))?;
        }
        Ok(())
    }
}

/// The file in a checkpoint that lists the SHA-256 of every other file in it, written last.
pub const DIGESTS: &str = "digests.json";

/// The SHA-256 of `path`'s contents, hex.
pub(crate) fn sha256_of(path: &Path) -> Result<String, TrainError> {
    use sha2::Digest;
    let mut file = std::fs::File::open(path).map_err(|e| TrainError::io(path, e))?;
    let mut hasher = sha2::Sha256::new();
    std::io::copy(&mut file, &mut hasher).map_err(|e| TrainError::io(path, e))?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Lists the SHA-256 of every file in checkpoint folder `dir` in [`DIGESTS`].
pub(crate) fn write_digests(dir: &Path) -> Result<(), TrainError> {
    let mut digests = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(dir).map_err(|e| TrainError::io(dir, e))? {
        let path = entry.map_err(|e| TrainError::io(dir, e))?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if path.is_file() && name != DIGESTS {
            digests.insert(name, sha256_of(&path)?);
        }
    }
    let text = serde_json::to_string_pretty(&digests).unwrap_or_default();
    write_atomic(&dir.join(DIGESTS), &text)
}

/// Checks checkpoint folder `dir` against its [`DIGESTS`]: every listed file present with the
/// contents it had when written. A checkpoint written before digests existed has none and is
/// taken as it is.
pub fn verify_checkpoint(dir: &Path) -> Result<(), TrainError> {
    let list = dir.join(DIGESTS);
    if !list.is_file() {
        return Ok(());
    }
    let digests: std::collections::BTreeMap<String, String> = read_json(&list)?;
    for (name, want) in digests {
        let path = dir.join(&name);
        if !path.is_file() {
            return Err(TrainError::Corrupt {
                path: path.display().to_string(),
                reason: format!("missing: the checkpoint lists it in {DIGESTS}"),
            });
        }
        if sha256_of(&path)? != want {
            return Err(TrainError::Corrupt {
                path: path.display().to_string(),
                reason: format!(
                    "its contents differ from the SHA-256 {DIGESTS} recorded when the checkpoint \
                     was written (changed or damaged since); restore it or start the run afresh"
                ),
            });
        }
    }
    Ok(())
}

/// Reads a JSON run file; a file that does not parse is reported as corrupt, with its path.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, TrainError> {
    let text = std::fs::read_to_string(path).map_err(|e| TrainError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| TrainError::Corrupt {
        path: path.display().to_string(),
        reason: e.to_string(),
    })
}

/// Refuses to resume `run_dir` when `requested` differs from the configuration the checkpoint
/// was written with, naming every differing field.
pub fn check_resume<C: serde::Serialize>(
    saved: &C,
    requested: &C,
    run_dir: &Path,
) -> Result<(), TrainError> {
    let differing = crate::differing_fields(saved, requested);
    if differing.is_empty() {
        Ok(())
    } else {
        Err(TrainError::ResumeMismatch {
            dir: run_dir.display().to_string(),
            fields: differing.join(", "),
        })
    }
}

/// Writes `text` to `path` atomically (`joca_core::fs::write_atomic`).
pub fn write_atomic(path: &Path, text: &str) -> Result<(), TrainError> {
    joca_core::fs::write_atomic(path, text.as_bytes()).map_err(|e| TrainError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_keeps_the_previous_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let ckpt = CheckpointDir::new(dir.path().join("checkpoint"));
        assert!(ckpt.existing().is_none());
        ckpt.write(|d| std::fs::write(d.join("state"), "1").map_err(|e| TrainError::io(d, e)))
            .unwrap();
        let failed = ckpt.write(|d| {
            std::fs::write(d.join("state"), "2").map_err(|e| TrainError::io(d, e))?;
            Err(TrainError::Corrupt { path: "x".into(), reason: "disk full".into() })
        });
        assert!(failed.is_err());
        let existing = ckpt.existing().unwrap();
        assert_eq!(std::fs::read_to_string(existing.join("state")).unwrap(), "1");
        // A crash between the renames leaves only `.old`; it is found.
        std::fs::rename(dir.path().join("checkpoint"), dir.path().join("checkpoint.old")).unwrap();
        assert_eq!(ckpt.existing().unwrap(), dir.path().join("checkpoint.old"));
    }
}
