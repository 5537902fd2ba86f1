//! The layering of the desktop crate (see the README, "Architecture"): a
//! top-level module of `std-ext/src` may use the modules before it in
//! [`LAYERS`], never one after it. This reads the source, so an import
//! cycle between stages fails here before it can settle in.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules, lowest first.
const LAYERS: &[&str] = &[
    "units", "model", "io", "fe", "reduce", "tables", "campbell", "simulate", "signals",
    "estimate", "diagnose", "report", "cli",
];

fn rank(module: &str) -> Option<usize> {
    LAYERS.iter().position(|m| *m == module)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).expect("readable source folder") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level module a source file belongs to (`None` for `lib.rs`,
/// `main.rs`).
fn owner(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

/// `crate::<module>` paths used in code (comments and doc comments skipped).
fn crate_uses(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.lines() {
        let code = match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        };
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            let tail = &rest[i + "crate::".len()..];
            let name: String = tail
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.insert(name);
            }
            rest = tail;
        }
    }
    out
}

#[test]
fn top_level_modules_only_use_lower_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("std-ext/src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    assert!(files.len() > 20, "found only {} source files", files.len());
    let mut violations = Vec::new();
    let mut owners = BTreeSet::new();
    for file in &files {
        let Some(module) = owner(&src, file) else {
            continue;
        };
        owners.insert(module.clone());
        let Some(own) = rank(&module) else {
            violations.push(format!(
                "{}: module `{module}` is not in LAYERS",
                file.display()
            ));
            continue;
        };
        let text = fs::read_to_string(file).expect("readable source file");
        for used in crate_uses(&text) {
            if used == "core" {
                continue; // rotorid_core, below every layer
            }
            match rank(&used) {
                Some(r) if r <= own => {}
                Some(_) => violations.push(format!(
                    "{}: `{module}` uses the higher layer `{used}`",
                    file.display()
                )),
                None => violations.push(format!(
                    "{}: `crate::{used}` is not a top-level module in LAYERS",
                    file.display()
                )),
            }
        }
    }
    assert!(
        violations.is_empty(),
        "layering violations:\n{}",
        violations.join("\n")
    );
    // Every listed layer that exists is seen, so the list cannot go stale.
    for m in &owners {
        assert!(rank(m).is_some(), "{m}");
    }
}

#[test]
fn the_checker_sees_a_violation() {
    let uses = crate_uses("use crate::report::plot; // crate::cli in a comment\n/// [`crate::x`]");
    assert_eq!(
        uses.into_iter().collect::<Vec<_>>(),
        vec!["report".to_string()]
    );
}
