//! Every experiment file the repository ships resolves into its cells, as `joca experiment
//! --prepare` writes them: a results page's command keeps working after the run configuration
//! gains or renames a field. Files that need data the repository does not hold (recordings) are
//! refused saying what to pass.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use std::path::Path;

mod common;
use common::{cli, stderr};

#[test]
fn every_shipped_experiment_file_resolves_into_its_cells() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<_> = std::fs::read_dir(root.join("experiments"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 20, "{files:?}");
    for file in files {
        let name = file.file_stem().unwrap().to_string_lossy().into_owned();
        let out = dir.path().join(&name);
        let o = cli!("experiment", file.clone(), "--prepare --out", out.clone());
        if name == "real" {
            assert!(!o.status.success());
            assert!(stderr(&o).contains("source = \"waymo:DIR\""), "{}", stderr(&o));
            continue;
        }
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let cells = std::fs::read_dir(out.join("cells")).unwrap().count();
        assert!(cells >= 2, "{name}: {cells} cells");
    }
}
