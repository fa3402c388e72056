//! Output folders: which folders a joca command may write into, and one writer at a time.
//!
//! Every command that writes a folder claims it first ([`claim`]): a folder that does not exist
//! or is empty becomes the command's, marked by a [`MARKER`] file naming the kind of output; a
//! folder holding that marker for the same kind is continued (or replaced, by the commands that
//! stage their output); anything else — a user's folder, another command's output, a file — is
//! refused, naming what is there. The marker is the only evidence: a file name a user may also
//! have (`annotations.json`, `config.toml`) is never taken for joca's.
//!
//! A run directory (and an experiment) is written by one process at a time: [`DirLock`] holds
//! an OS advisory lock on [`LOCK_FILE`] for the writer's lifetime. The OS releases it when the
//! holder exits or is killed, so a `kill -9` never blocks the next `--resume`.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The file that marks a folder as joca's output; it holds `joca-output <kind>`.
pub const MARKER: &str = ".joca-output";
/// The file a writer locks ([`DirLock`]); it holds the current holder's description.
pub const LOCK_FILE: &str = ".joca-lock";

crate::named_enum! {
    /// What a folder holds, as its [`MARKER`] names it.
    pub enum OutputKind("output kind") {
        /// A run directory (`joca run`, an experiment's cell).
        Run = "run",
        /// An experiment directory (`joca experiment`).
        Experiment = "experiment",
        /// Rendered frames (`joca render`).
        Render = "render",
        /// An imported recording (`joca import`).
        Import = "import",
        /// Motion-blurred frames (`joca blur`).
        Blur = "blur",
        /// A detector pre-training directory (`joca train-detector`).
        Pretrain = "pretrain",
    }
}

impl OutputKind {
    fn marker_text(self) -> String {
        format!("joca-output {}\n", self.name())
    }

    fn from_marker(text: &str) -> Option<Self> {
        let name = text.trim().strip_prefix("joca-output ")?;
        Self::from_name(name.trim()).ok()
    }
}

/// Why a folder cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The path is a file (or another non-folder).
    #[error("{} is not a folder: choose a folder path for the output", path.display())]
    NotAFolder {
        /// The path.
        path: PathBuf,
    },
    /// The folder holds another command's output.
    #[error(
        "{} holds joca {} output, not {}: choose another folder", path.display(), found, wanted
    )]
    OtherKind {
        /// The folder.
        path: PathBuf,
        /// What its marker names.
        found: String,
        /// What the command writes.
        wanted: &'static str,
    },
    /// The folder is not empty and joca did not write it.
    #[error(
        "{} is not empty and is not a joca {} output (no {MARKER} marker; it holds {}): choose a \
         new folder, or empty it. (A {} folder written by joca before output markers existed: add \
         the marker with `printf 'joca-output {}\\n' > {}/{MARKER}`.)",
        path.display(), wanted, listing, wanted, wanted, path.display()
    )]
    Foreign {
        /// The folder.
        path: PathBuf,
        /// What the command writes.
        wanted: &'static str,
        /// A few of its entries.
        listing: String,
    },
    /// Another process writes the folder, or reads it while this one would write it.
    #[error(
        "{} is in use by another joca process ({holder}); wait for it to end, or choose another \
         folder", path.display()
    )]
    Locked {
        /// The folder.
        path: PathBuf,
        /// The holder's description, from the lock file.
        holder: String,
    },
    /// A file operation failed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done.
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> OutputError {
    let path = path.to_owned();
    move |source| OutputError::Io { action, path, source }
}

/// What [`claim`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Claimed {
    /// The folder was new or empty; it is now marked.
    New,
    /// The folder held this kind's marker: an earlier output of the same command.
    Earlier,
}

/// The kind a folder's marker names (None: no marker, or one joca cannot read).
pub fn marked_kind(dir: &Path) -> Option<OutputKind> {
    std::fs::read_to_string(dir.join(MARKER)).ok().and_then(|t| OutputKind::from_marker(&t))
}

/// Checks that `dir` may hold `kind`'s output without writing anything (see the module doc).
/// `Ok(None)`: the folder does not exist or is empty.
pub fn check(dir: &Path, kind: OutputKind) -> Result<Option<Claimed>, OutputError> {
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A dangling symbolic link would be created through; refuse it as not a folder.
            return if dir.symlink_metadata().is_ok() {
                Err(OutputError::NotAFolder { path: dir.to_owned() })
            } else {
                Ok(None)
            };
        }
        Err(e) => return Err(io("read", dir)(e)),
    };
    if !meta.is_dir() {
        return Err(OutputError::NotAFolder { path: dir.to_owned() });
    }
    if let Some(found) = marked_kind(dir) {
        return if found == kind {
            Ok(Some(Claimed::Earlier))
        } else {
            Err(OutputError::OtherKind {
                path: dir.to_owned(),
                found: found.name().to_owned(),
                wanted: kind.name(),
            })
        };
    }
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map_err(io("list", dir))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    if names.is_empty() {
        return Ok(None);
    }
    names.sort();
    let more = names.len().saturating_sub(4);
    names.truncate(4);
    let mut listing = names.join(", ");
    if more > 0 {
        listing.push_str(&format!(" and {more} more"));
    }
    Err(OutputError::Foreign { path: dir.to_owned(), wanted: kind.name(), listing })
}

/// Claims `dir` for `kind`'s output: creates and marks a new or empty folder, accepts an earlier
/// output of the same kind, refuses anything else naming what is there (see the module doc).
pub fn claim(dir: &Path, kind: OutputKind) -> Result<Claimed, OutputError> {
    if let Some(claimed) = check(dir, kind)? {
        return Ok(claimed);
    }
    mark(dir, kind)?;
    Ok(Claimed::New)
}

/// Creates `dir` (and its parents) and writes `kind`'s marker into it, whatever it holds: for a
/// folder joca has just made (a staging folder, an experiment's cell).
pub fn mark(dir: &Path, kind: OutputKind) -> Result<(), OutputError> {
    std::fs::create_dir_all(dir).map_err(io("create", dir))?;
    let marker = dir.join(MARKER);
    crate::fs::write_atomic(&marker, kind.marker_text().as_bytes()).map_err(io("write", &marker))
}

/// An exclusive advisory lock on a folder's [`LOCK_FILE`], held until dropped (or until the
/// process ends, however it ends).
#[derive(Debug)]
pub struct DirLock {
    _file: File,
}

/// Who holds `dir`'s lock now (its description), or `None` where no process does; the lock is
/// only tried, never kept.
pub fn lock_holder(dir: &Path) -> Option<String> {
    let mut file = File::open(dir.join(LOCK_FILE)).ok()?;
    match file.try_lock_shared() {
        Ok(()) => None,
        Err(TryLockError::WouldBlock) => {
            let mut text = String::new();
            let _ = file.read_to_string(&mut text);
            Some(if text.trim().is_empty() { "holder unknown".into() } else { text.trim().into() })
        }
        Err(TryLockError::Error(_)) => None,
    }
}

impl DirLock {
    /// Takes the lock of `dir` for `holder` (what the lock file tells a refused second writer,
    /// e.g. "joca run"), or refuses naming the current holder.
    pub fn acquire(dir: &Path, holder: &str) -> Result<Self, OutputError> {
        Self::take(dir, holder, false)
    }

    /// Takes the lock of `dir` for reading: any number of readers hold it at once, no writer
    /// while they do, and none while a writer does (refused naming the writer).
    pub fn acquire_shared(dir: &Path, holder: &str) -> Result<Self, OutputError> {
        Self::take(dir, &format!("{holder}, reading"), true)
    }

    fn take(dir: &Path, holder: &str, shared: bool) -> Result<Self, OutputError> {
        let path = dir.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io("open", &path))?;
        match if shared { file.try_lock_shared() } else { file.try_lock() } {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut text = String::new();
                let _ = file.read_to_string(&mut text);
                let holder = match text.trim() {
                    "" => "holder unknown".to_owned(),
                    t => t.to_owned(),
                };
                return Err(OutputError::Locked { path: dir.to_owned(), holder });
            }
            Err(TryLockError::Error(e)) => return Err(io("lock", &path)(e)),
        }
        let since = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let text = format!("{holder}, process {}, since unix time {since}\n", std::process::id());
        file.set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| file.write_all(text.as_bytes()))
            .map_err(io("write", &path))?;
        Ok(Self { _file: file })
    }
}

#[cfg(test)]
mod tests;
