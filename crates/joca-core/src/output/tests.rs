use super::*;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("joca-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn a_new_folder_is_marked_and_continued_only_by_its_own_kind() {
    let dir = scratch("new");
    assert_eq!(claim(&dir, OutputKind::Run).unwrap(), Claimed::New);
    assert_eq!(std::fs::read_to_string(dir.join(MARKER)).unwrap(), "joca-output run\n");
    assert_eq!(claim(&dir, OutputKind::Run).unwrap(), Claimed::Earlier);
    let e = claim(&dir, OutputKind::Render).unwrap_err().to_string();
    assert!(e.contains("holds joca run output, not render"), "{e}");
    // An empty folder is claimed like a new one.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    assert_eq!(claim(&empty, OutputKind::Blur).unwrap(), Claimed::New);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_users_folder_is_refused_naming_what_it_holds_and_left_untouched() {
    let dir = scratch("foreign");
    std::fs::create_dir_all(&dir).unwrap();
    // The file names joca writes itself do not make a folder joca's.
    for name in ["annotations.json", "config.toml", "notes.txt", "report.md", "results.csv"] {
        std::fs::write(dir.join(name), "mine").unwrap();
    }
    let e = claim(&dir, OutputKind::Import).unwrap_err().to_string();
    assert!(e.contains(&dir.display().to_string()), "{e}");
    assert!(e.contains("annotations.json, config.toml, notes.txt, report.md and 1 more"), "{e}");
    assert!(!dir.join(MARKER).exists());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 5);
    // A marker joca cannot read is no marker.
    std::fs::write(dir.join(MARKER), "something else").unwrap();
    assert!(matches!(claim(&dir, OutputKind::Run), Err(OutputError::Foreign { .. })));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_file_or_a_dangling_link_is_not_a_folder() {
    let dir = scratch("file");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("out");
    std::fs::write(&file, "data").unwrap();
    let e = claim(&file, OutputKind::Render).unwrap_err();
    assert!(matches!(e, OutputError::NotAFolder { .. }), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "data");
    #[cfg(unix)]
    {
        let link = dir.join("link");
        std::os::unix::fs::symlink(dir.join("nowhere"), &link).unwrap();
        assert!(matches!(claim(&link, OutputKind::Run), Err(OutputError::NotAFolder { .. })));
        assert!(!dir.join("nowhere").exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn one_writer_holds_the_lock_and_the_next_gets_it_when_it_ends() {
    let dir = scratch("lock");
    claim(&dir, OutputKind::Run).unwrap();
    let first = DirLock::acquire(&dir, "joca run").unwrap();
    // A second open file description is refused, whatever process holds it, naming the holder.
    let e = DirLock::acquire(&dir, "joca eval").unwrap_err().to_string();
    assert!(e.contains("in use by another joca process (joca run, process"), "{e}");
    // A reader waits for the writer too.
    let e = DirLock::acquire_shared(&dir, "joca headroom").unwrap_err().to_string();
    assert!(e.contains("(joca run, process"), "{e}");
    drop(first);
    let second = DirLock::acquire(&dir, "joca eval").unwrap();
    let text = std::fs::read_to_string(dir.join(LOCK_FILE)).unwrap();
    assert!(text.starts_with("joca eval, process "), "{text}");
    drop(second);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn readers_share_the_lock_and_keep_writers_out() {
    let dir = scratch("shared");
    claim(&dir, OutputKind::Run).unwrap();
    let one = DirLock::acquire_shared(&dir, "joca headroom").unwrap();
    let two = DirLock::acquire_shared(&dir, "joca headroom").unwrap();
    // A writer is refused while either reads, naming a reader; `lock_holder` (is anyone
    // writing?) says no one.
    let e = DirLock::acquire(&dir, "joca run").unwrap_err().to_string();
    assert!(e.contains("in use by another joca process (joca headroom, reading, process"), "{e}");
    assert_eq!(lock_holder(&dir), None);
    drop(one);
    assert!(DirLock::acquire(&dir, "joca run").is_err());
    drop(two);
    drop(DirLock::acquire(&dir, "joca run").unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}
