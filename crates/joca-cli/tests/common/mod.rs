//! What the `joca` binary's test files share: running it, reading its output, a tiny run.
// Each test file uses what it needs of this.
#![allow(dead_code)]

use std::process::{Command, Output};

/// Runs the `joca` binary with `args`.
pub fn joca(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_joca")).args(args).output().expect("joca runs")
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A `[run]` small enough for a test: 1 generation of 2 candidates, 3 steps each.
pub const TINY_RUN: &str = "[run]\nthreads = 1\ngenerations = 1\npopulation = 2\n\
                            steps_per_candidate = 3\ntest_episodes = 1\ntest_frames_per_episode = 2\n";
