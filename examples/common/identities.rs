//! Who is in which photo, for the likeness examples: deepface's identity lists, or one folder
//! per person (LFW's layout, `Person_Name/Person_Name_0001.jpg`).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;

/// Photo path (relative to `dir`) -> person number: from the "Yes" rows of deepface's pair
/// lists when `dir` has them, else from one sub-folder per person.
pub fn identities(dir: &Path) -> Result<BTreeMap<String, usize>> {
    if !dir.join("master.csv").exists() && !dir.join("face-recognition-pivot.csv").exists() {
        return folders(dir);
    }
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

/// One sub-folder per person: every JPEG or PNG in `dir/PERSON/` is PERSON's (people with
/// fewer than two photos are left out: they cannot have a fellow).
fn folders(dir: &Path) -> Result<BTreeMap<String, usize>> {
    let mut people: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    people.sort();
    let mut out = BTreeMap::new();
    let mut id = 0;
    for person in people {
        let mut photos: Vec<String> = std::fs::read_dir(dir.join(&person))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| {
                let n = n.to_ascii_lowercase();
                n.ends_with(".jpg") || n.ends_with(".jpeg") || n.ends_with(".png")
            })
            .collect();
        if photos.len() < 2 {
            continue;
        }
        photos.sort();
        for p in photos {
            out.insert(format!("{person}/{p}"), id);
        }
        id += 1;
    }
    anyhow::ensure!(
        !out.is_empty(),
        "{}: no identity lists (deepface's master.csv) and no folders of two or more photos per person",
        dir.display()
    );
    Ok(out)
}
