//! The committed headroom panels against the checks `joca headroom --panel` makes.

use super::*;

/// Every headroom panel in experiments/headroom/ reads, passes its checks, and gives each of
/// its designs a run configuration its preset accepts (the `trained` run directories are not
/// checked: they live on the machine that trained them).
#[test]
fn every_headroom_panel_in_the_repository_is_valid() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/headroom");
    let files = crate::io::files_with_extension(&dir, "toml").unwrap();
    for path in &files {
        let source = path.display().to_string();
        let text = std::fs::read_to_string(path).unwrap();
        let panel: HeadroomPanel =
            toml::from_str(&text).unwrap_or_else(|e| panic!("{source}: {e}"));
        check(&panel, &source).unwrap_or_else(|e| panic!("{e:#}"));
        let designs = panel.panel.as_ref().map(|p| p.resolve(&source));
        for d in designs.transpose().unwrap_or_else(|e| panic!("{e:#}")).unwrap_or_default() {
            let table = design_table(&panel, &d).unwrap_or_else(|e| panic!("{e:#}"));
            validate(&panel.preset, table, &source).unwrap_or_else(|e| panic!("{e:#}"));
        }
        assert!(panel.panel.is_some() || !panel.trained.is_empty(), "{source}: nothing to measure");
    }
    assert!(files.len() >= 6, "only {} panels in {}", files.len(), dir.display());
}
