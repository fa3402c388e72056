//! What the `joca` binary's test files share: running it, reading its output, a tiny run.
// Each test file uses what it needs of this.
#![allow(dead_code)]

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `joca` binary with `args`.
pub fn joca(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_joca")).args(args).output().expect("joca runs")
}

/// A piece of a command line: text is split into words at whitespace, a path or a built string
/// stays one argument.
pub trait Part {
    /// Appends the piece's arguments.
    fn push_to(&self, args: &mut Vec<OsString>);
}

impl Part for &str {
    fn push_to(&self, args: &mut Vec<OsString>) {
        args.extend(self.split_whitespace().map(OsString::from));
    }
}

impl Part for String {
    fn push_to(&self, args: &mut Vec<OsString>) {
        args.push(self.into());
    }
}

impl Part for PathBuf {
    fn push_to(&self, args: &mut Vec<OsString>) {
        args.push(self.into());
    }
}

impl Part for &Path {
    fn push_to(&self, args: &mut Vec<OsString>) {
        args.push(self.into());
    }
}

/// Runs the `joca` binary with a command line given as [`Part`]s.
pub fn joca_parts(parts: &[&dyn Part]) -> Output {
    let mut args = Vec::new();
    for p in parts {
        p.push_to(&mut args);
    }
    Command::new(env!("CARGO_BIN_EXE_joca")).args(args).output().expect("joca runs")
}

/// `cli!("form --input", input, "--exposure-ms 10 --out", out)`: runs the `joca` binary, each
/// text split into words, each path one argument.
#[allow(unused_macros)]
macro_rules! cli {
    ($($part:expr),+ $(,)?) => {
        $crate::common::joca_parts(&[$(&$part as &dyn $crate::common::Part),+])
    };
}
#[allow(unused_imports)]
pub(crate) use cli;

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
