//! The documentation's front door: `README.md` stays one screen (under
//! [`README_MAX_BYTES`]), every relative Markdown link of `README.md`,
//! `ARCHITECTURE.md`, `core/README.md` and `docs/**/*.md` points to a file
//! that exists, and every `#anchor` to a heading of that file; the README's
//! library snippet compiles ([`readme_library_snippet`]).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

/// `README.md` must stay below this size (bytes).
const README_MAX_BYTES: u64 = 10_240;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The Markdown files whose links are checked, relative to the root.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let root = root();
    let mut files: Vec<PathBuf> = ["README.md", "ARCHITECTURE.md", "core/README.md"]
        .iter()
        .map(|f| root.join(f))
        .collect();
    walk(&root.join("docs"), &mut files);
    files
}

/// The lines of `text` with fenced code blocks blanked (line numbers kept).
fn prose_lines(text: &str) -> Vec<&str> {
    let mut fence: Option<&str> = None;
    text.lines()
        .map(|line| {
            let t = line.trim_start_matches(' ');
            let marker = ["```", "~~~"].into_iter().find(|m| t.starts_with(m));
            match (fence, marker) {
                (None, Some(m)) => {
                    fence = Some(m);
                    ""
                }
                (Some(f), Some(m)) if f == m => {
                    fence = None;
                    ""
                }
                (Some(_), _) => "",
                (None, None) => line,
            }
        })
        .collect()
}

/// `line` without its inline code spans (`` `...` ``, ``` ``...`` ```).
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(start) = rest.find('`') {
        out.push_str(&rest[..start]);
        let run = rest[start..].len() - rest[start..].trim_start_matches('`').len();
        let ticks = &rest[start..start + run];
        let after = &rest[start + run..];
        // The span closes at the next run of exactly as many backticks.
        let mut search = 0;
        let mut close = None;
        while let Some(i) = after[search..].find(ticks) {
            let at = search + i;
            let len = after[at..].len() - after[at..].trim_start_matches('`').len();
            if len == run {
                close = Some(at + run);
                break;
            }
            search = at + len;
        }
        match close {
            Some(end) => rest = &after[end..],
            None => {
                out.push_str(ticks);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The targets of the inline links `[text](target)` of `text`, with their
/// 1-based line numbers; code blocks and code spans are skipped, a title
/// (`[text](target "title")`) is dropped.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in prose_lines(text).into_iter().enumerate() {
        let line = without_code_spans(line);
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let tail = &rest[at + 2..];
            let Some(end) = tail.find(')') else { break };
            let target = tail[..end].split_whitespace().next().unwrap_or("");
            let target = target.trim_start_matches('<').trim_end_matches('>');
            out.push((i + 1, target.to_string()));
            rest = &tail[end..];
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation
/// other than `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of the ATX headings of `text` (a repeated heading gets
/// `-1`, `-2`, ... as on GitHub).
fn anchors(text: &str) -> Vec<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = Vec::new();
    for line in prose_lines(text) {
        let hashes = line.len() - line.trim_start_matches('#').len();
        if !(1..=6).contains(&hashes) || !line[hashes..].starts_with([' ', '\t']) {
            continue;
        }
        let title = line[hashes..].trim().trim_end_matches('#').trim_end();
        let s = slug(title);
        let n = seen.entry(s.clone()).or_insert(0);
        out.push(if *n == 0 {
            s.clone()
        } else {
            format!("{s}-{n}")
        });
        *n += 1;
    }
    out
}

/// What is wrong with the relative links of `file` (whose text is `text`):
/// one message per link to a missing file or heading.
fn broken_links(file: &Path, text: &str) -> Vec<String> {
    let dir = file.parent().expect("a file has a folder");
    let mut problems = Vec::new();
    for (line, target) in links(text) {
        if ["http://", "https://", "mailto:"]
            .iter()
            .any(|p| target.starts_with(p))
        {
            continue;
        }
        let (path, anchor) = match target.split_once('#') {
            Some((p, a)) => (p, Some(a)),
            None => (target.as_str(), None),
        };
        let place = format!("{}:{line}: ({target})", file.display());
        let linked = if path.is_empty() {
            file.to_path_buf()
        } else {
            dir.join(path)
        };
        if path.is_empty() && anchor.is_none() {
            problems.push(format!("{place}: empty link"));
            continue;
        }
        if !linked.exists() {
            problems.push(format!("{place}: no file {}", linked.display()));
            continue;
        }
        if let Some(anchor) = anchor {
            let heads = if linked == file {
                anchors(text)
            } else if linked.is_file() {
                anchors(&fs::read_to_string(&linked).unwrap_or_default())
            } else {
                Vec::new()
            };
            if !heads.iter().any(|h| h == anchor) {
                problems.push(format!(
                    "{place}: no heading #{anchor} in {}",
                    linked.display()
                ));
            }
        }
    }
    problems
}

#[test]
fn readme_is_one_screen() {
    let path = root().join("README.md");
    let size = fs::metadata(&path).expect("README.md").len();
    assert!(
        size < README_MAX_BYTES,
        "README.md is {size} bytes, the limit is {README_MAX_BYTES}: move the detail to docs/"
    );
}

#[test]
fn relative_links_resolve() {
    let files = markdown_files();
    assert!(
        files.len() > 3,
        "docs/ holds no Markdown file: {}",
        files.len()
    );
    let mut problems = Vec::new();
    for file in &files {
        let text = fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        problems.extend(broken_links(file, &text));
    }
    assert!(
        problems.is_empty(),
        "broken links:\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_link_checker_finds_what_is_broken() {
    assert_eq!(
        slug("Output error and Cramér-Rao bounds"),
        "output-error-and-cramér-rao-bounds"
    );
    assert_eq!(
        slug("Model structures (`--formulation`, `--order P`)"),
        "model-structures---formulation---order-p"
    );
    let text =
        "# Title\n\n## Part one\n\n## Part one\n\n```sh\n# not a heading\n[x](nowhere.md)\n```\n\
                [ok](#part-one) [ok too](#part-one-1) [web](https://example.invalid/x)\n\
                `[code](nowhere.md)` [bad anchor](#part-two) [bad file](nowhere.md#title)\n\
                [self](docs.rs) [titled](docs.rs \"a title\")\n";
    assert_eq!(anchors(text), ["title", "part-one", "part-one-1"]);
    let file = root().join("tests").join("docs.rs");
    let problems = broken_links(&file, text);
    assert_eq!(problems.len(), 2, "{problems:#?}");
    assert!(
        problems[0].contains("no heading #part-two"),
        "{problems:#?}"
    );
    assert!(problems[1].contains("no file"), "{problems:#?}");
}

/// The README's library snippet, compiled (not run): it must stay what the
/// library offers.
#[allow(dead_code)]
fn readme_library_snippet() -> Result<(), Box<dyn std::error::Error>> {
    let model = rotorid::io::model_file::model_by_name_or_path("paper")?;
    let meas = rotorid::io::measurement::read_csv("sweep.csv")?;
    let id = rotorid::identify(&model, &meas, &rotorid::IdentifyOptions::default())?;
    let b1 = &id.last.bearings[0]; // K (N/m), C (N s/m) as [yy, yz, zy, zz]
    println!(
        "K {:?} C {:?} m e {} kg m",
        b1.k, b1.c, id.last.unbalance[0].me
    );
    Ok(())
}

#[test]
fn readme_shows_the_compiled_library_snippet() {
    let readme = fs::read_to_string(root().join("README.md")).expect("README.md");
    for line in [
        "let model = rotorid::io::model_file::model_by_name_or_path(\"paper\")?;",
        "let meas = rotorid::io::measurement::read_csv(\"sweep.csv\")?;",
        "let id = rotorid::identify(&model, &meas, &rotorid::IdentifyOptions::default())?;",
    ] {
        assert!(readme.contains(line), "README.md lacks the line {line:?}");
    }
}
