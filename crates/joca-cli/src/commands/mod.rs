//! One module per subcommand: its arguments (`Args`) and its `run`.

pub mod bench;
pub mod calibrate;
pub mod detect;
pub mod eval;
pub mod experiment;
pub mod export;
pub mod flow;
pub mod form;
pub mod headroom;
pub mod import;
pub mod metrics;
pub mod render;
pub mod report;
pub mod run;
pub mod sensors;
pub mod slurm;
pub mod train_detector;

use anyhow::{Result, bail};

/// Parses `WIDTHxHEIGHT` (e.g. `1920x1280`).
pub fn parse_resolution(text: &str) -> Result<(usize, usize)> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    if let [w, h] = parts.as_slice()
        && let (Ok(w), Ok(h)) = (w.trim().parse::<usize>(), h.trim().parse::<usize>())
        && w > 0
        && h > 0
    {
        return Ok((w, h));
    }
    bail!("expected WIDTHxHEIGHT in pixels, e.g. 1920x1280, got {text:?}")
}

/// What a parent runs its children (grid cells, headroom measurements) with: this very program.
/// On Linux that is `/proc/self/exe`, the image this process was started from, even after the
/// file at its path has been rebuilt (a build replaces the file; the running image stays), so a
/// grid left running for hours computes every cell with the code it started with and its records
/// name one commit. Elsewhere the path this process was started from.
pub fn own_executable() -> Result<std::path::PathBuf> {
    let this = std::path::Path::new("/proc/self/exe");
    if this.exists() {
        return Ok(this.to_path_buf());
    }
    anyhow::Context::context(std::env::current_exe(), "cannot find the joca executable")
}
