//! ARCHITECTURE.md stays a true map: the crate layering it states holds in `cargo metadata`, and
//! every `file:symbol` it names exists.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

fn map() -> String {
    std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap()
}

/// The layers as ARCHITECTURE.md lists them, top first (the block under "## Crates").
fn layers(text: &str) -> Vec<String> {
    let section = text.split("## Crates").nth(1).unwrap();
    let block = section.split("```").nth(1).unwrap();
    block
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|w| w.starts_with("joca-"))
        .map(str::to_owned)
        .collect()
}

/// Every workspace package's direct dependencies (normal, build and dev), by name.
fn dependencies() -> BTreeMap<String, Vec<(String, Option<String>)>> {
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    meta["packages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .map(|d| {
                    (d["name"].as_str().unwrap().to_owned(), d["kind"].as_str().map(str::to_owned))
                })
                .collect();
            (p["name"].as_str().unwrap().to_owned(), deps)
        })
        .collect()
}

#[test]
fn the_crate_layering_holds() {
    let order = layers(&map());
    let deps = dependencies();
    let listed: BTreeSet<&String> = order.iter().collect();
    let crates: BTreeSet<&String> = deps.keys().collect();
    assert_eq!(listed, crates, "ARCHITECTURE.md lists every workspace crate once");
    let rank = |name: &str| order.iter().position(|c| c == name);
    for (name, list) in &deps {
        for (dep, kind) in list {
            if dep == "tch" || dep == "torch-sys" {
                assert_eq!(name, "joca-nn", "{name} uses {dep}: only joca-nn may");
            }
            if let Some(r) = rank(dep) {
                // Arrows point down for every kind of dependency, tests' included.
                assert!(
                    r > rank(name).unwrap(),
                    "{name} depends on {dep} ({kind:?}), which is not below it in ARCHITECTURE.md"
                );
            }
        }
    }
    for base in ["joca-core", "joca-evolve"] {
        assert!(
            deps[base].iter().all(|(d, _)| !d.starts_with("joca-")),
            "{base}: {:?}",
            deps[base]
        );
    }
    // joca-report reads records: nothing of training or libtorch, even indirectly.
    let mut reach = BTreeSet::new();
    let mut todo = vec!["joca-report".to_owned()];
    while let Some(c) = todo.pop() {
        for (d, kind) in deps.get(&c).into_iter().flatten() {
            if kind.as_deref() != Some("dev") && reach.insert(d.clone()) {
                todo.push(d.clone());
            }
        }
    }
    for forbidden in ["joca-train", "joca-nn", "joca-sim", "joca-data", "tch"] {
        assert!(!reach.contains(forbidden), "joca-report reaches {forbidden}: {reach:?}");
    }
}

/// `crates/…/file.rs:Symbol` or `:Type::item` references in backticks.
fn references(text: &str) -> Vec<(String, String)> {
    let mut refs = Vec::new();
    for quoted in text.split('`').skip(1).step_by(2) {
        if let Some((file, symbol)) = quoted.split_once(".rs:")
            && file.starts_with("crates/")
        {
            refs.push((format!("{file}.rs"), symbol.to_owned()));
        }
    }
    refs
}

#[test]
fn every_file_and_symbol_the_map_names_exists() {
    let text = map();
    let refs = references(&text);
    assert!(refs.len() >= 40, "the map names {} symbols", refs.len());
    let defines = |source: &str, name: &str| {
        ["fn", "struct", "enum", "trait", "const", "type", "mod", "macro_rules!"].iter().any(|kw| {
            source.match_indices(&format!("{kw} {name}")).any(|(i, m)| {
                let next = source[i + m.len()..].chars().next();
                !next.is_some_and(|c| c.is_alphanumeric() || c == '_')
            })
        })
    };
    for (file, symbol) in refs {
        let path = root().join(&file);
        let source = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("ARCHITECTURE.md names {file}, which cannot be read: {e}"));
        let parts: Vec<&str> = symbol.split("::").collect();
        let item = parts.last().unwrap();
        assert!(
            defines(&source, item),
            "ARCHITECTURE.md names {file}:{symbol}; {item} is not there"
        );
        if parts.len() == 2 {
            assert!(source.contains(parts[0]), "{file}:{symbol}: {} is not there", parts[0]);
        }
    }
}

#[test]
fn the_map_stays_short() {
    let lines = map().lines().count();
    assert!(lines <= 160, "ARCHITECTURE.md has {lines} lines: a map is read in five minutes");
}
