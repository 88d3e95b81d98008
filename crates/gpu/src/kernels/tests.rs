//! Checks of the kernels' sources that need no device: naga compiles every composed kernel, and
//! no WGSL file reads a laid-out buffer by number.

use super::kernel_sources;

/// naga's WGSL front end and validator, with the f64 capability the context asks the device
/// for, over every kernel exactly as the context composes it.
#[test]
fn every_kernel_compiles() {
    use naga::valid::{Capabilities, ValidationFlags, Validator};
    let mut failures = Vec::new();
    // NVIDIA's binding limit through wgpu.
    for (name, source) in kernel_sources((1 << 31) - 1) {
        let module = match naga::front::wgsl::parse_str(&source) {
            Ok(m) => m,
            Err(e) => {
                failures.push(format!("{name}: {}", e.emit_to_string(&source)));
                continue;
            }
        };
        // The host binds buffers by their place in a list: the bindings must be 0, 1, 2, ...
        let mut bindings: Vec<u32> = module
            .global_variables
            .iter()
            .filter_map(|(_, v)| v.binding.as_ref().map(|b| b.binding))
            .collect();
        bindings.sort_unstable();
        if bindings.iter().enumerate().any(|(k, &b)| b != k as u32) {
            failures.push(format!(
                "{name}: bindings {bindings:?} are not 0, 1, 2, ..."
            ));
        }
        // The fewest storage bindings a kernel may have that a device we run on allows
        // (lavapipe's 32).
        if bindings.len() > 32 {
            failures.push(format!("{name}: {} bindings, over 32", bindings.len()));
        }
        let mut validator = Validator::new(ValidationFlags::all(), Capabilities::FLOAT64);
        match validator.validate(&module) {
            Err(e) => failures.push(format!("{name}: {}", e.emit_to_string(&source))),
            // wgpu leaves a binding the kernel never uses out of the layout it derives, and the
            // host's bind group, which binds every one, would then be refused.
            Ok(info) => {
                let main = info.get_entry_point(0);
                for (handle, var) in module.global_variables.iter() {
                    if var.binding.is_some() && main[handle].is_empty() {
                        let what = var.name.as_deref().unwrap_or("?");
                        failures.push(format!("{name}: binding {what} is never used"));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Constants whose literal is not a place in a buffer: how many wall contacts a thread keeps,
/// and the cell hash's multipliers.
const ALLOWED_CONSTS: &[&str] = &["KEEP", "HASH_X", "HASH_Y", "HASH_Z", "HASH_WORLD"];

/// Keywords whose parentheses group an expression or a loop header rather than pass arguments.
const KEYWORDS: &[&str] = &["for", "if", "while", "switch", "return", "loop", "else"];

#[derive(Clone, Debug, PartialEq)]
enum Token {
    Ident(String),
    /// A decimal integer literal: its value and whether it is a u32 (`u` suffix).
    Int(u64, bool),
    /// A float or hexadecimal literal (sentinels and masks): never a place.
    OtherNumber,
    Punct(char),
}

/// The tokens of `source` with their line numbers, comments left out.
fn tokens(source: &str) -> Vec<(usize, Token)> {
    let mut out = Vec::new();
    for (row, line) in source.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let chars: Vec<char> = code.chars().collect();
        let mut k = 0;
        while k < chars.len() {
            let c = chars[k];
            let starts_number = c.is_ascii_digit()
                || (c == '.' && chars.get(k + 1).is_some_and(char::is_ascii_digit));
            if c.is_whitespace() {
                k += 1;
            } else if c.is_alphabetic() || c == '_' {
                let start = k;
                while k < chars.len() && (chars[k].is_alphanumeric() || chars[k] == '_') {
                    k += 1;
                }
                out.push((row + 1, Token::Ident(chars[start..k].iter().collect())));
            } else if starts_number {
                let start = k;
                let hex = c == '0' && matches!(chars.get(k + 1), Some('x' | 'X'));
                let mut float = false;
                if hex {
                    k += 2;
                }
                while k < chars.len() {
                    let d = chars[k];
                    let exponent_sign = !hex
                        && matches!(d, '+' | '-')
                        && matches!(chars[k - 1], 'e' | 'E')
                        && float;
                    if d == '.' || (!hex && matches!(d, 'e' | 'E')) {
                        float = true;
                    } else if !(d.is_alphanumeric() || exponent_sign) {
                        break;
                    }
                    k += 1;
                }
                let text: String = chars[start..k].iter().collect();
                let digits = text.trim_end_matches(['u', 'i']);
                let token = match digits.parse::<u64>() {
                    Ok(v) if !hex && !float => Token::Int(v, text.ends_with('u')),
                    _ => Token::OtherNumber,
                };
                out.push((row + 1, token));
            } else {
                out.push((row + 1, Token::Punct(c)));
                k += 1;
            }
        }
    }
    out
}

/// Places where `source` seems to index a laid-out buffer by number: line and what was found.
///
/// The rule: an integer literal is a suspect when it is a u32 (every index, offset, stride and
/// code in the kernels is one) or sits inside an index `[...]` or a call's arguments (as in
/// `param(11)`). A suspect of 2 or more is flagged, and so is any literal that is a whole index
/// (`ctrl[1]`, `counts[0]`), except:
/// - `3u * i` or `3u * j`: a vector's width times a particle's index within a block of vectors;
/// - `+ 2u` ending an index or argument: the third component of a vector (`+ 1u` the second);
/// - the literal of a constant named in [`ALLOWED_CONSTS`].
///
/// Loop counters and array sizes in i32 or abstract literals (`k < 3`, `array<u32, 27>`), and
/// attributes (`@binding(12)`, `@workgroup_size(64)`), are not suspects.
fn positional_literals(source: &str) -> Vec<(usize, String)> {
    #[derive(PartialEq)]
    enum Open {
        Index,
        Call,
        Group,
    }
    let toks = tokens(source);
    let mut found = Vec::new();
    let mut open: Vec<Open> = Vec::new();
    // The constant being declared, from `const NAME` to its `;`.
    let mut constant: Option<String> = None;
    let ident = |k: usize| match toks.get(k) {
        Some((_, Token::Ident(s))) => Some(s.as_str()),
        _ => None,
    };
    let punct = |k: usize| match toks.get(k) {
        Some((_, Token::Punct(c))) => Some(*c),
        _ => None,
    };
    for (k, (line, tok)) in toks.iter().enumerate() {
        let before = k.checked_sub(1);
        match tok {
            Token::Ident(s) if s == "const" => constant = ident(k + 1).map(str::to_string),
            Token::Punct(';') => constant = None,
            Token::Punct('[') => open.push(Open::Index),
            Token::Punct('(') => {
                let callee = before.and_then(ident);
                let attribute = k >= 2 && punct(k - 2) == Some('@');
                let call = callee.is_some_and(|c| !KEYWORDS.contains(&c)) && !attribute;
                open.push(if call { Open::Call } else { Open::Group });
            }
            Token::Punct(')' | ']') => {
                open.pop();
            }
            &Token::Int(value, unsigned) => {
                let whole_index = before.and_then(punct) == Some('[') && punct(k + 1) == Some(']');
                let suspect = unsigned || open.iter().any(|o| *o != Open::Group);
                let vector_width = value == 3
                    && unsigned
                    && punct(k + 1) == Some('*')
                    && matches!(ident(k + 2), Some("i" | "j"));
                let third_component = value == 2
                    && unsigned
                    && before.and_then(punct) == Some('+')
                    && matches!(punct(k + 1), Some(']' | ')'));
                let allowed_const = constant
                    .as_deref()
                    .is_some_and(|c| ALLOWED_CONSTS.contains(&c));
                let exempt = vector_width || third_component || allowed_const;
                if whole_index || (suspect && value >= 2 && !exempt) {
                    let text = source.lines().nth(line - 1).unwrap_or("").trim();
                    found.push((*line, format!("{value}: {text}")));
                }
            }
            _ => {}
        }
    }
    found
}

/// Every `.wgsl` file under `dir`, recursively.
fn wgsl_files(dir: &std::path::Path, into: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("the kernels' folder") {
        let path = entry.expect("a folder entry").path();
        if path.is_dir() {
            wgsl_files(&path, into);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            into.push(path);
        }
    }
}

/// The kernels read every laid-out buffer through the generated names (`layout.rs`).
#[test]
fn no_wgsl_file_indexes_a_layout_by_number() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/wgsl");
    let mut files = Vec::new();
    wgsl_files(&root, &mut files);
    files.sort();
    assert!(files.len() > 10, "found only {files:?}");
    let mut report = Vec::new();
    for path in &files {
        let source = std::fs::read_to_string(path).expect("a kernel file");
        for (line, what) in positional_literals(&source) {
            report.push(format!("{}:{line}: {what}", path.display()));
        }
    }
    assert!(
        report.is_empty(),
        "places written by number (name them in layout.rs):\n{}",
        report.join("\n")
    );
}

#[test]
fn the_scan_catches_numbered_places() {
    let flagged = [
        "let dt = param(11u);",
        "let dt = param(11);",
        "let s = atomicLoad(&ctrl[1]);",
        "let n = counts[0];",
        "history[6u * q + k] = 0.0lf;",
        "let v = get3(3u * n + 3u * i);",
        "let m = props[n + i] * props[2u * n + i];",
        "for (var k = 0u; k < 11u; k++) {}",
        "atomicMax(&ctrl[K_OVERFLOW], 2u);",
        "const PARAMS: u32 = 24u;",
        "let w = x[k + 2u + k];",
    ];
    for code in flagged {
        assert!(!positional_literals(code).is_empty(), "missed: {code}");
    }
    let clean = [
        "let v = state[S_VELOCITY * n + 3u * i];",
        "return vec3<f64>(a[k], a[k + 1u], a[k + 2u]);",
        "for (var k = 0; k < 3; k++) { y = y * 3.0lf; }",
        "@group(0) @binding(12) var<storage, read> rows: array<u32>;",
        "@compute @workgroup_size(64)",
        "var seen: array<u32, 27>;",
        "const KEEP: u32 = 32u;",
        "const NO_BODY: u32 = 0xffffffffu;",
        "let tol = 1.0e-9lf + 1.0e-6lf * r; let h = 0.5lf;",
        "for (var q = i * cap; q < (i + 1u) * cap; q++) {}",
        "let k = E_LEN * e; let c = el3(k + E_RECT_U);",
    ];
    for code in clean {
        assert_eq!(positional_literals(code), vec![], "flagged: {code}");
    }
}
