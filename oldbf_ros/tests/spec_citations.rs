//! Every citation of the spec ("ALGORITHM.md §4b", "ALGORITHM §1",
//! "ALGORITHM.md 5b") in the code, the configuration, the tests and the docs
//! resolves to a section heading of docs/ALGORITHM.md: a user who clones the
//! repository can read what the code cites.

mod common;

use std::fs;
use std::path::{Path, PathBuf};

/// Section numbers of docs/ALGORITHM.md: "## 4b. Liveness ..." gives "4b".
fn sections(spec: &str) -> Vec<String> {
    spec.lines()
        .filter_map(|l| l.strip_prefix("## "))
        .filter_map(|h| h.split_once(". ").map(|(n, _)| n.trim().to_string()))
        .filter(|n| n.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .collect()
}

/// Section numbers cited in `text`: after "ALGORITHM.md" or "ALGORITHM",
/// an optional "§", spaces, then digits and at most one lowercase letter.
fn citations(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices("ALGORITHM") {
        let rest = &text[i + "ALGORITHM".len()..];
        let rest = rest.strip_prefix(".md").unwrap_or(rest);
        let rest = rest.trim_start_matches([' ', ',']);
        let rest = rest.strip_prefix('§').unwrap_or(rest).trim_start();
        let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        if digits.is_empty() {
            continue;
        }
        let letter: String = rest[digits.len()..]
            .chars()
            .take(1)
            .filter(|c| c.is_ascii_lowercase())
            .collect();
        // "§4b" but not "§4 below": a letter counts only if no letter follows it.
        let next = rest[digits.len()..].chars().nth(1);
        let letter = if next.is_some_and(|c| c.is_ascii_alphabetic()) {
            String::new()
        } else {
            letter
        };
        out.push(format!("{digits}{letter}"));
    }
    out
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        let name = p.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if p.is_dir() {
            if !matches!(name.as_str(), "target" | ".git" | "corpus" | "artifacts" | "out") {
                files(&p, out);
            }
        } else if ["rs", "yaml", "md", "sh", "py", "cfg", "launch"]
            .iter()
            .any(|x| name.ends_with(&format!(".{x}")))
        {
            out.push(p);
        }
    }
}

#[test]
fn the_section_parser_reads_headings_and_citations() {
    assert_eq!(
        sections("# t\n## 1. Scan\ntext\n## 4b. Liveness\n## Notes\n"),
        ["1", "4b"]
    );
    assert_eq!(
        citations("(ALGORITHM.md §4b), ALGORITHM §1; ALGORITHM.md 5b. ALGORITHM.md §4 below"),
        ["4b", "1", "5b", "4"]
    );
}

#[test]
fn every_spec_citation_resolves_to_a_section_of_docs_algorithm_md() {
    let root = common::repo_root();
    let spec = fs::read_to_string(root.join("docs/ALGORITHM.md")).expect("docs/ALGORITHM.md is in the repository");
    let known = sections(&spec);
    for n in ["1", "2", "3", "4", "4b", "5", "5b", "6", "7", "8"] {
        assert!(
            known.iter().any(|k| k == n),
            "docs/ALGORITHM.md lacks section {n}: {known:?}"
        );
    }
    let mut paths = Vec::new();
    for d in ["oldbf_ros", "can_bridge", "config", "docs", "tests", "launch", "fuzz"] {
        files(&root.join(d), &mut paths);
    }
    paths.push(root.join("README.md"));
    let (mut cited, mut bad) = (0, Vec::new());
    for p in &paths {
        let Ok(text) = fs::read_to_string(p) else { continue };
        for c in citations(&text) {
            cited += 1;
            if !known.contains(&c) {
                bad.push(format!("{}: §{c}", p.strip_prefix(&root).unwrap_or(p).display()));
            }
        }
    }
    assert!(
        cited >= 40,
        "expected the code to cite the spec; found {cited} citations"
    );
    assert!(bad.is_empty(), "citations of missing sections: {bad:?}");
}
