//! The README and docs show only pictures that are in the repository: a picture made from a
//! third-party photo is ignored by git, and a link to it is a broken image wherever the
//! README is read (issue #39).

use std::path::{Path, PathBuf};
use std::process::Command;

/// Local picture references in a Markdown file: `![alt](path)` and `<img src="path">`, web
/// addresses left out.
fn pictures(markdown: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (open, close) in [("](", ')'), ("<img src=\"", '"')] {
        let mut rest = markdown;
        while let Some(i) = rest.find(open) {
            rest = &rest[i + open.len()..];
            let Some(j) = rest.find(close) else { break };
            let target = &rest[..j];
            let is_picture = [".png", ".jpg", ".jpeg", ".gif", ".svg"]
                .iter()
                .any(|e| target.to_ascii_lowercase().ends_with(e));
            if is_picture && !target.contains("://") {
                out.push(target.to_string());
            }
        }
    }
    out
}

#[test]
fn the_readme_and_docs_show_only_committed_pictures() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // What git tracks, where git is there (a fresh clone holds nothing else; a working copy
    // also holds the ignored pictures made from third-party photos).
    let tracked: Option<Vec<PathBuf>> = Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| {
            o.stdout
                .split(|&b| b == 0)
                .filter(|s| !s.is_empty())
                .map(|s| PathBuf::from(String::from_utf8_lossy(s).into_owned()))
                .collect()
        });
    let mut files = vec![PathBuf::from("README.md")];
    for entry in std::fs::read_dir(root.join("docs")).expect("docs/") {
        let path = entry.expect("docs entry").path();
        if path.extension().is_some_and(|e| e == "md") {
            files.push(
                path.strip_prefix(root)
                    .expect("under the root")
                    .to_path_buf(),
            );
        }
    }
    let mut missing = Vec::new();
    let mut seen = 0;
    for md in &files {
        let text = std::fs::read_to_string(root.join(md)).expect("markdown");
        let dir = md.parent().unwrap_or(Path::new(""));
        for picture in pictures(&text) {
            seen += 1;
            // Paths as git writes them: relative to the root, `..` resolved.
            let mut path = PathBuf::new();
            for part in dir.join(&picture).components() {
                match part {
                    std::path::Component::ParentDir => {
                        path.pop();
                    }
                    std::path::Component::CurDir => {}
                    other => path.push(other),
                }
            }
            let there = match &tracked {
                Some(t) => t.contains(&path),
                None => root.join(&path).is_file(),
            };
            if !there {
                missing.push(format!("{}: {picture}", md.display()));
            }
        }
    }
    assert!(
        seen >= 5,
        "only {seen} pictures found: the parser is broken"
    );
    assert!(
        missing.is_empty(),
        "pictures not in the repository: {missing:?}"
    );
}

#[test]
fn picture_references_are_parsed() {
    let md = "![a](docs/x.png) [link](BENCHMARKS.md) <img src=\"y.jpg\" width=1> ![w](https://e.org/z.png)";
    assert_eq!(pictures(md), ["docs/x.png", "y.jpg"]);
}
