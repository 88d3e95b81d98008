//! `docs/reference.md` is checked against the code: every key a scene, test or study file's
//! reader accepts is in the reference under its section, and every key the reference lists in a
//! section is one the code accepts, so the reference cannot go stale either way.

use std::path::Path;

/// The reference's sections: `### <name>` headings, each with its text up to the next heading.
fn sections(text: &str) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("### ") {
            out.push((name.trim().to_string(), String::new()));
        } else if line.starts_with("## ") || line.starts_with("# ") {
            out.push((String::new(), String::new()));
        } else if let Some(last) = out.last_mut() {
            last.1.push_str(line);
            last.1.push('\n');
        }
    }
    out
}

/// The keys a section's table documents: the first cell of each row, in backticks (a row may
/// give several keys, `` `a` / `b` ``).
fn documented(body: &str) -> Vec<String> {
    let mut keys = Vec::new();
    for line in body.lines() {
        let Some(row) = line.strip_prefix('|') else {
            continue;
        };
        let cell = row.split('|').next().unwrap_or("");
        if cell.trim_start().starts_with("---") || cell.trim() == "Key" {
            continue;
        }
        let mut rest = cell;
        while let Some(a) = rest.find('`') {
            let Some(b) = rest[a + 1..].find('`') else {
                break;
            };
            keys.push(rest[a + 1..a + 1 + b].to_string());
            rest = &rest[a + 2 + b..];
        }
    }
    keys
}

#[test]
fn every_key_the_code_accepts_is_in_the_reference_and_no_other() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/reference.md");
    let text = std::fs::read_to_string(&path).expect("docs/reference.md exists");
    let doc = sections(&text);
    let mut code: Vec<(String, Vec<&'static str>)> = Vec::new();
    code.extend(
        dem::scene::parse::reference_sections()
            .into_iter()
            .map(|(s, k)| (s.to_string(), k)),
    );
    code.extend(virtual_tests::registry::reference_sections());
    code.extend(study::load::reference_sections());
    let mut faults = Vec::new();
    for (section, keys) in &code {
        let Some((_, body)) = doc.iter().find(|(name, _)| name == section) else {
            faults.push(format!(
                "no section \"### {section}\" (keys: {})",
                keys.join(", ")
            ));
            continue;
        };
        let listed = documented(body);
        for k in keys {
            if !listed.iter().any(|l| l == k) {
                faults.push(format!("{section}: `{k}` is accepted but not documented"));
            }
        }
        for l in &listed {
            if !keys.contains(&l.as_str()) {
                faults.push(format!(
                    "{section}: `{l}` is documented but the code does not accept it"
                ));
            }
        }
    }
    for (name, _) in &doc {
        if !name.is_empty() && !code.iter().any(|(s, _)| s == name) {
            faults.push(format!(
                "\"### {name}\" is not a section the code knows (sections are: {})",
                code.iter()
                    .map(|(s, _)| s.as_str())
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
        }
    }
    assert!(
        faults.is_empty(),
        "docs/reference.md is out of date:\n{}",
        faults.join("\n")
    );
}
