//! deepface's identity lists, shared by the likeness examples.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;

/// Identities from the "Yes" rows of deepface's pair lists: photo name -> person number.
pub fn identities(dir: &Path) -> Result<BTreeMap<String, usize>> {
    let mut parent: BTreeMap<String, String> = BTreeMap::new();
    fn find(p: &mut BTreeMap<String, String>, x: &str) -> String {
        let mut x = x.to_string();
        loop {
            let up = p.entry(x.clone()).or_insert_with(|| x.clone()).clone();
            if up == x {
                return x;
            }
            x = up;
        }
    }
    for list in ["master.csv", "face-recognition-pivot.csv"] {
        let path = dir.join(list);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            if f.len() < 3 || !f[2].eq_ignore_ascii_case("yes") {
                continue;
            }
            let name = |s: &str| s.rsplit('/').next().unwrap_or(s).to_string();
            let (a, b) = (name(f[0]), name(f[1]));
            let (ra, rb) = (find(&mut parent, &a), find(&mut parent, &b));
            if ra != rb {
                parent.insert(ra, rb);
            }
        }
    }
    anyhow::ensure!(
        !parent.is_empty(),
        "{}: no master.csv or face-recognition-pivot.csv with same-person pairs",
        dir.display()
    );
    let names: Vec<String> = parent.keys().cloned().collect();
    let mut roots: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeMap::new();
    for n in names {
        let r = find(&mut parent, &n);
        let k = roots.len();
        let id = *roots.entry(r).or_insert(k);
        out.insert(n, id);
    }
    Ok(out)
}
