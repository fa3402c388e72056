//! [`DataError`]: why recorded data (a frame folder, Waymo Parquet, a label or flow file) cannot
//! be read or written. Every variant names the file; the underlying failure (the operating
//! system's, the JSON, image or Parquet decoder's) is kept as the error's `source`, so a caller
//! that prints the chain shows it.

use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why recorded data cannot be read or written.
#[derive(Debug, Error)]
pub enum DataError {
    /// The operating system refused a file or folder (read, list, create, copy, write).
    #[error("{}: cannot {action}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What was attempted ("read", "list the folder", …).
        action: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A JSON file is not JSON, or not of the layout joca reads there.
    #[error("{}: not {layout}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The layout expected ("a COCO annotations file", "a labelme file").
        layout: &'static str,
        /// The decoder's error (with line and column).
        #[source]
        source: serde_json::Error,
    },
    /// An image cannot be decoded or its size read.
    #[error("{}: cannot decode {what}", path.display())]
    Image {
        /// The file (or, for frames inside a Parquet file, the frame's label).
        path: PathBuf,
        /// What the image was ("frame 7", "the image").
        what: String,
        /// The decoder's error.
        #[source]
        source: image::ImageError,
    },
    /// A Parquet file cannot be opened or one of its rows read.
    #[error("{}: cannot read the Parquet data", path.display())]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The reader's error.
        #[source]
        source: parquet::errors::ParquetError,
    },
    /// The file reads, but what it says is wrong: a box outside its image, a missing field, a
    /// number out of range. `reason` names the entry and the allowed values.
    #[error("{}{}: {reason}", path.display(), Line(*line))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The line, for text formats.
        line: Option<usize>,
        /// What is wrong, and what would be right.
        reason: String,
    },
}

/// `:N` after a path, or nothing.
struct Line(Option<usize>);

impl fmt::Display for Line {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.map_or(Ok(()), |l| write!(f, ":{l}"))
    }
}

impl DataError {
    /// The file's content is wrong (`reason` says how).
    pub fn invalid(path: &Path, reason: impl Into<String>) -> Self {
        Self::Invalid { path: path.to_path_buf(), line: None, reason: reason.into() }
    }

    /// Line `line` of a text file is wrong.
    pub fn invalid_at(path: &Path, line: Option<usize>, reason: impl Into<String>) -> Self {
        Self::Invalid { path: path.to_path_buf(), line, reason: reason.into() }
    }

    /// `action` on `path` failed in the operating system.
    pub fn io(path: &Path, action: impl Into<String>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        let action = action.into();
        move |source| Self::Io { path, action, source }
    }

    /// `path` is not the JSON `layout` says.
    pub fn json(path: &Path, layout: &'static str) -> impl FnOnce(serde_json::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Json { path, layout, source }
    }

    /// The Parquet file `path` cannot be read.
    pub fn parquet(path: &Path) -> impl FnOnce(parquet::errors::ParquetError) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Parquet { path, source }
    }

    /// The file the error names.
    pub fn path(&self) -> &Path {
        match self {
            Self::Io { path, .. }
            | Self::Json { path, .. }
            | Self::Image { path, .. }
            | Self::Parquet { path, .. }
            | Self::Invalid { path, .. } => path,
        }
    }

    /// The message and its causes on one line ("a: b: c"), for warnings that are collected as
    /// text (a skipped frame).
    pub fn with_causes(&self) -> String {
        let mut text = self.to_string();
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            text.push_str(": ");
            text.push_str(&c.to_string());
            cause = c.source();
        }
        text
    }
}

impl From<DataError> for joca_core::SourceError {
    fn from(e: DataError) -> Self {
        Self::Recorded(Box::new(e))
    }
}

#[cfg(test)]
mod tests {
    use super::DataError;
    use std::path::Path;

    #[test]
    fn every_error_names_its_file_and_keeps_its_cause() {
        let missing = std::fs::read(Path::new("/no/such/dir/annotations.json"))
            .map_err(DataError::io(Path::new("/no/such/dir/annotations.json"), "read"))
            .unwrap_err();
        assert_eq!(missing.to_string(), "/no/such/dir/annotations.json: cannot read");
        assert!(std::error::Error::source(&missing).is_some());
        assert!(missing.with_causes().starts_with("/no/such/dir/annotations.json: cannot read: "));
        let json = serde_json::from_str::<serde_json::Value>("{")
            .map_err(DataError::json(Path::new("a.json"), "a COCO annotations file"))
            .unwrap_err();
        assert_eq!(json.to_string(), "a.json: not a COCO annotations file");
        assert!(json.with_causes().contains("line 1"), "{}", json.with_causes());
        let at = DataError::invalid_at(Path::new("0007.txt"), Some(3), "unknown type \"Tram\"");
        assert_eq!(at.to_string(), "0007.txt:3: unknown type \"Tram\"");
        assert_eq!(at.path(), Path::new("0007.txt"));
        // Through a frame source the cause stays in the chain.
        let source: joca_core::SourceError = missing.into();
        assert_eq!(source.to_string(), "/no/such/dir/annotations.json: cannot read");
        assert!(std::error::Error::source(&source).is_some());
    }
}
