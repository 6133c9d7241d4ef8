//! The docs stay true by themselves: every relative link in README.md and docs/ resolves (the
//! file, and the heading when the link names one), the README stays short, and it names no
//! commit.

use std::path::{Path, PathBuf};

use crate::fixtures::repo;

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> Vec<String> {
    let mut fenced = false;
    text.lines()
        .filter(|l| {
            if l.starts_with("```") {
                fenced = !fenced;
            }
            !fenced
        })
        .filter_map(|l| {
            l.trim_start_matches('#')
                .strip_prefix(' ')
                .filter(|_| l.starts_with('#'))
        })
        .map(anchor)
        .collect()
}

/// `(target, line)` of every inline link `[text](target)` outside code.
fn links(text: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.starts_with("```") {
            fenced = !fenced;
        }
        if fenced {
            continue;
        }
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            out.push((after[..end].to_string(), i + 1));
            rest = &after[end..];
        }
    }
    out
}

fn markdown_files() -> Vec<PathBuf> {
    let mut files = vec![repo("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo("docs"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    let mut broken = Vec::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        let dir = file.parent().unwrap_or(Path::new("."));
        for (target, line) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, heading) = match target.split_once('#') {
                Some((p, h)) => (p, Some(h)),
                None => (target.as_str(), None),
            };
            let resolved = if path.is_empty() {
                file.clone()
            } else {
                dir.join(path)
            };
            let name = format!("{}:{line}: {target}", file.display());
            if !resolved.exists() {
                broken.push(format!("{name} (no such file)"));
                continue;
            }
            if let Some(h) = heading
                && resolved.extension().is_some_and(|e| e == "md")
            {
                let text = std::fs::read_to_string(&resolved).unwrap();
                if !anchors(&text).iter().any(|a| a == h) {
                    broken.push(format!("{name} (no such heading)"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_readme_is_short_and_names_no_commit() {
    let text = std::fs::read_to_string(repo("README.md")).unwrap();
    let lines = text.lines().count();
    assert!(lines <= 200, "README.md has {lines} lines; at most 200");
    // A commit hash: 7 to 40 hex digits with a letter and a digit among them, as a word.
    let hashes: Vec<&str> = text
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| {
            (7..=40).contains(&w.len())
                && w.chars()
                    .all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase())
                && w.chars().any(|c| c.is_ascii_digit())
                && w.chars().any(|c| c.is_ascii_alphabetic())
        })
        .collect();
    assert!(hashes.is_empty(), "README.md names commits: {hashes:?}");
}

#[test]
fn anchors_follow_githubs_rule() {
    assert_eq!(anchor("Reproduce's folder"), "reproduces-folder");
    assert_eq!(
        anchor("Recorded hand keypoints (`import --keypoints`)"),
        "recorded-hand-keypoints-import---keypoints"
    );
    assert_eq!(
        anchor("See it: the player and nightly comparisons"),
        "see-it-the-player-and-nightly-comparisons"
    );
}

/// Where docs/RESULTS.md carries the committed `reproduce` run's tables.
const GENERATED_BEGIN: &str = "<!-- generated from reports/latest/summary.md: do not edit; \
     DEXWARP_WRITE_DOCS=1 cargo test --test it docs::results rewrites it -->";
const GENERATED_END: &str = "<!-- end of the generated part -->";

/// The committed run's summary without its title: the run's revision and machine line, then
/// every table with its notes.
fn committed_tables() -> String {
    let summary = std::fs::read_to_string(repo("reports/latest/summary.md")).unwrap();
    let body = summary
        .lines()
        .skip_while(|l| l.starts_with("# ") || l.trim().is_empty())
        .collect::<Vec<_>>()
        .join("\n");
    format!("{}\n", body.trim_end())
}

#[test]
fn results_carry_the_committed_runs_tables() {
    let path = repo("docs/RESULTS.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let (Some(begin), Some(end)) = (text.find(GENERATED_BEGIN), text.find(GENERATED_END)) else {
        panic!("docs/RESULTS.md has no generated part (its two markers)");
    };
    let start = begin + GENERATED_BEGIN.len() + 1;
    let tables = committed_tables();
    if std::env::var_os("DEXWARP_WRITE_DOCS").is_some() {
        let written = format!("{}{tables}{}", &text[..start], &text[end..]);
        std::fs::write(&path, written).unwrap();
        println!("rewrote the generated part of {}", path.display());
        return;
    }
    assert!(
        text[start..end] == tables,
        "docs/RESULTS.md's tables differ from reports/latest/summary.md's; after a new committed \
         run: DEXWARP_WRITE_DOCS=1 cargo test --test it docs::results"
    );
}
