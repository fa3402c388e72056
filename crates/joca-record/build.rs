//! Embeds the git commit this joca was built from, and whether the working tree differed from
//! it, so that every record a run writes names the code that made it (`provenance`).

use std::path::Path;
use std::process::Command;

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").arg("-C").arg(root).args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

fn main() {
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default();
    let root = Path::new(&manifest).join("../..");
    // Any change to the sources, presets, lock file or the checked-out commit rebuilds the
    // record (cargo scans a directory named here for any file that changed).
    for path in ["crates", "presets", "weights", "Cargo.lock"] {
        println!("cargo:rerun-if-changed={}", root.join(path).display());
    }
    // Git's own files, found through git (a worktree keeps HEAD and its index apart from the
    // refs): HEAD names the branch, a commit moves the branch's ref (loose, or packed). Only files
    // that exist are named: cargo rebuilds on every build while a named file is missing.
    let mut git_files = vec!["HEAD".to_owned(), "index".to_owned(), "packed-refs".to_owned()];
    git_files.extend(git(&root, &["symbolic-ref", "-q", "HEAD"]));
    for name in git_files {
        if let Some(path) = git(&root, &["rev-parse", "--git-path", &name]) {
            let path = root.join(path);
            if path.exists() {
                println!("cargo:rerun-if-changed={}", path.display());
            }
        }
    }
    let commit = git(&root, &["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    // Tracked files only: an untracked scratch file does not change what the binary runs.
    let dirty = match git(&root, &["status", "--porcelain", "--untracked-files=no"]) {
        Some(s) => {
            if s.is_empty() {
                "false"
            } else {
                "true"
            }
        }
        None => "unknown",
    };
    println!("cargo:rustc-env=JOCA_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=JOCA_GIT_DIRTY={dirty}");
}
