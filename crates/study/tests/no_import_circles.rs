//! The study crate's modules import each other in layers, never in a circle: plain types at the
//! bottom (`text`, `limits`, `store`, `target`, `record`), what a study is (`spec`, with the
//! `Stage` and `Executor` traits), the shared machinery and report parts, the stages and
//! executors, and on top their registries, the loader, the replay and the report. This test reads
//! `src/` and fails naming the modules of any circle. An edge is a `crate::a::b` or `super::x`
//! path outside comments and test modules, and a registry's line (`stages!`, `executors!`) from
//! the registry to the module it names.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Module name (`stage::sweep`) and its source, for every file under `dir`.
fn modules(dir: &Path, prefix: &[String], out: &mut BTreeMap<String, String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            let mut p = prefix.to_vec();
            p.push(path.file_name().unwrap().to_string_lossy().into_owned());
            modules(&path, &p, out);
            continue;
        }
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let mut parts = prefix.to_vec();
        if stem != "mod" {
            parts.push(stem);
        }
        let name = if parts == ["lib"] {
            "lib".to_string()
        } else {
            parts.join("::")
        };
        out.insert(name, std::fs::read_to_string(&path).unwrap());
    }
}

/// The source without comments and without its `#[cfg(test)] mod tests`.
fn code(src: &str) -> String {
    let src = src.split("#[cfg(test)]\nmod tests").next().unwrap();
    src.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every `word::word::...` path starting at `at` in `s`.
fn paths_after(s: &str, at: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (i, _) in s.match_indices(at) {
        let before = s[..i].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let rest = &s[i + at.len()..];
        let mut parts = Vec::new();
        let mut cur = rest;
        loop {
            let n = cur
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(cur.len());
            if n == 0 {
                break;
            }
            parts.push(cur[..n].to_string());
            if !cur[n..].starts_with("::") {
                break;
            }
            cur = &cur[n + 2..];
        }
        out.push(parts);
    }
    out
}

/// The longest module named by the start of `path`.
fn resolve(path: &[String], known: &BTreeSet<String>) -> Option<String> {
    (1..=path.len())
        .rev()
        .map(|n| path[..n].join("::"))
        .find(|m| known.contains(m))
}

fn edges(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let known: BTreeSet<String> = mods.keys().cloned().collect();
    let mut g = BTreeMap::new();
    for (name, src) in mods {
        let src = code(src);
        let here: Vec<String> = if name == "lib" {
            Vec::new()
        } else {
            name.split("::").map(String::from).collect()
        };
        let mut out = BTreeSet::new();
        for p in paths_after(&src, "crate::") {
            out.extend(resolve(&p, &known));
        }
        // `super::x` from a module file: its parent's x (from a mod.rs, the parent is itself).
        let parent = &here[..here.len().saturating_sub(1)];
        for p in paths_after(&src, "super::") {
            let full: Vec<String> = parent.iter().cloned().chain(p).collect();
            out.extend(resolve(&full, &known));
        }
        // A registry names its modules: `stages! { sweep::Sweep, ... }`.
        for mac in ["stages! {", "executors! {"] {
            if let Some(i) = src.find(mac) {
                let body = &src[i + mac.len()..];
                let body = &body[..body.find('}').unwrap()];
                for item in body.split(',') {
                    if let Some((m, _)) = item.trim().split_once("::") {
                        let full: Vec<String> =
                            here.iter().cloned().chain([m.to_string()]).collect();
                        out.extend(resolve(&full, &known));
                    }
                }
            }
        }
        out.remove(name);
        // lib.rs declares every module and re-exports a few; nothing imports it back.
        if name != "lib" {
            out.remove("lib");
        }
        g.insert(name.clone(), out);
    }
    g
}

/// Tarjan's strongly connected components with more than one module.
fn circles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.g[v] {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut c = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                c.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if c.len() > 1 {
                c.sort();
                t.out.push(c);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn the_study_crate_has_no_import_circle() {
    let mut mods = BTreeMap::new();
    modules(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
        &[],
        &mut mods,
    );
    assert!(mods.len() > 40, "read {} modules", mods.len());
    let g = edges(&mods);
    // The checker sees the edges it must: a stage imports the replay's records and the spec.
    assert!(g["stage::sweep"].contains("spec") && g["stage::sweep"].contains("record"));
    assert!(
        g["stage"].contains("stage::sweep"),
        "the registry's lines are edges"
    );
    let found = circles(&g);
    assert!(
        found.is_empty(),
        "modules importing each other in a circle: {}",
        found
            .iter()
            .map(|c| c.join(" <-> "))
            .collect::<Vec<_>>()
            .join("; ")
    );
}

#[test]
fn the_checker_finds_a_circle() {
    let mut g = BTreeMap::new();
    g.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    g.insert("b".to_string(), BTreeSet::from(["c".to_string()]));
    g.insert("c".to_string(), BTreeSet::from(["a".to_string()]));
    g.insert("d".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(circles(&g), vec![vec!["a", "b", "c"]]);
}
