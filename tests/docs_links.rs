//! Every relative link in the README and in `docs/` resolves to a file in
//! the repository (anchors are not checked, only the file they are in):
//! the user guide and the developer pages link into each other and into the
//! sources, and a page that moves must not leave a dead link behind. Links
//! to web pages (`http:`, `https:`, `mailto:`) and in-page anchors (`#x`)
//! are left alone.

use std::path::{Path, PathBuf};

/// The Markdown files: the README and everything under `docs/`.
fn pages(root: &Path) -> Vec<PathBuf> {
    let mut out = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The targets of `[text](target)` and `![alt](target)` links in `text`,
/// outside code spans and fenced blocks, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (n, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // drop code spans
        let mut plain = String::new();
        for (k, part) in line.split('`').enumerate() {
            if k % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let tail = &rest[i + 2..];
            let Some(j) = tail.find(')') else { break };
            out.push((n + 1, tail[..j].trim().to_string()));
            rest = &tail[j..];
        }
    }
    out
}

#[test]
fn every_relative_link_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut dead = Vec::new();
    let mut checked = 0;
    for page in pages(root) {
        let text = std::fs::read_to_string(&page).unwrap();
        for (line, target) in links(&text) {
            if target.starts_with('#')
                || ["http://", "https://", "mailto:"]
                    .iter()
                    .any(|s| target.starts_with(s))
            {
                continue;
            }
            let file = target.split('#').next().unwrap();
            let resolved = page.parent().unwrap().join(file);
            checked += 1;
            if !resolved.exists() {
                dead.push(format!(
                    "{}:{line}: `{target}` does not resolve",
                    page.strip_prefix(root).unwrap().display()
                ));
            }
        }
    }
    assert!(dead.is_empty(), "dead links:\n{}", dead.join("\n"));
    // the README alone links to a dozen guide and developer pages
    assert!(checked > 20, "only {checked} links checked");
}

#[test]
fn the_link_scanner_sees_links_and_skips_code() {
    let text = "a [x](one.md) b ![y](two.png)\n`[z](three.md)`\n```\n[w](four.md)\n```\n[v](five.md#part)\n";
    let found: Vec<String> = links(text).into_iter().map(|(_, t)| t).collect();
    assert_eq!(found, ["one.md", "two.png", "five.md#part"]);
}
