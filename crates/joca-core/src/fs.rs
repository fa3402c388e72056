//! Files written whole or not at all.

use std::path::{Path, PathBuf};

/// The temporary sibling [`write_atomic`] writes first: `<file name>.partial` beside `path`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Writes `bytes` to `path` through a temporary sibling ([`partial_path`]) and a rename, so a
/// failure (a full disk, a kill) leaves the earlier file, or none, under `path` — never a
/// truncated one. On an error the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = partial_path(path);
    let written = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_replaced_whole_and_a_failed_write_leaves_nothing_behind() {
        let dir = std::env::temp_dir().join(format!("joca-core-fs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("results.json");
        assert_eq!(partial_path(&path), dir.join("results.json.partial"));
        write_atomic(&path, b"first").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert!(!partial_path(&path).exists());
        // The target is a directory: the rename fails, the earlier contents stay, no temporary.
        let blocked = dir.join("blocked");
        std::fs::create_dir_all(blocked.join("inside")).unwrap();
        assert!(write_atomic(&blocked, b"x").is_err());
        assert!(blocked.join("inside").is_dir());
        assert!(!partial_path(&blocked).exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
