//! The panel's measurements as child `joca headroom` processes, at most `--jobs` at once, each
//! with its log beside its folder.

use super::{HeadroomPanel, Measurement, Subject};
use anyhow::{Context, Result};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Instant;

/// Runs the measurements as child processes, at most `jobs` at once (measurements of one trained
/// run too: each only reads it, sharing its directory's lock).
pub(super) fn run_children(
    panel: &HeadroomPanel,
    configs: &Path,
    todo: &[&Measurement],
    jobs: usize,
) -> Result<()> {
    let exe = crate::commands::own_executable()?;
    let started = Instant::now();
    let mut queue = todo.iter().copied();
    // (name, child, start).
    let mut running: Vec<(String, Child, Instant)> = Vec::new();
    let (mut done, total) = (0usize, todo.len());
    loop {
        while running.len() < jobs {
            let Some(m) = queue.next() else { break };
            let child = spawn(&exe, panel, configs, m, jobs)?;
            let name = format!("{} {} town {}", m.design, m.scenario.name(), m.town);
            running.push((name, child, Instant::now()));
        }
        if running.is_empty() {
            return Ok(());
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
        let mut i = 0;
        while i < running.len() {
            if let Some(status) = running[i].1.try_wait()? {
                let (name, _, t) = running.remove(i);
                done += 1;
                let verdict = if status.success() { "done  " } else { "FAILED" };
                println!(
                    "  [{done:>3}/{total}] {verdict} {name}  ({:.1} min; elapsed {:.1} min)",
                    t.elapsed().as_secs_f64() / 60.0,
                    started.elapsed().as_secs_f64() / 60.0
                );
            } else {
                i += 1;
            }
        }
    }
}

fn spawn(
    exe: &Path,
    panel: &HeadroomPanel,
    configs: &Path,
    m: &Measurement,
    jobs: usize,
) -> Result<Child> {
    let parent = m.dir.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .with_context(|| format!("cannot create {}", parent.display()))?;
    let log_path = parent.join(format!("{}.log", m.design));
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    let mut command = Command::new(exe);
    if jobs > 1 && std::env::var_os("OMP_WAIT_POLICY").is_none() {
        // As `joca experiment`: libtorch's OpenMP threads would spin on the shared cores.
        command.env("OMP_WAIT_POLICY", "PASSIVE");
    }
    command.arg("headroom");
    match &m.subject {
        Subject::Design => {
            command.arg("--preset").arg(&panel.preset);
        }
        Subject::Trained(dir) => {
            let kind = super::tunnels_of(panel, "the panel file")?.kind;
            command.arg(dir).arg("--tunnels").arg(kind.name());
        }
    }
    command
        .arg("--config")
        .arg(configs.join(format!("{}.toml", m.design)))
        .arg("--scenario")
        .arg(m.scenario.name())
        .arg("--town")
        .arg(m.town.to_string())
        .arg("--out")
        .arg(&m.dir);
    if let Some(e) = panel.episodes {
        command.arg("--episodes").arg(e.to_string());
    }
    if let Some(f) = panel.frames {
        command.arg("--frames").arg(f.to_string());
    }
    command
        .stdout(Stdio::from(log.try_clone()?))
        .stderr(Stdio::from(log))
        .spawn()
        .with_context(|| format!("cannot start {}", exe.display()))
}
