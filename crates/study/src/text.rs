//! Text the report and the messages share: HTML escaping, how numbers and names are written.
//! The bottom of the crate: it imports nothing of it.

use std::collections::BTreeSet;

/// `s` safe inside HTML text and attribute values.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A name for a narrow column heading: it may break after its underscores.
pub(crate) fn breakable(name: &str) -> String {
    esc(name).replace('_', "_<wbr>")
}

/// The letter a parameter goes by in tables (A, B, ... without I, as Design-Expert names factors).
pub(crate) fn letter(i: usize) -> String {
    doe::design::factor_letter(i)
}

/// `v` to 12 significant digits: coded-to-actual arithmetic leaves 0.29999999999999993 where the
/// design means 0.3, and stored values, fingerprints and tables should say 0.3.
pub fn tidy(v: f64) -> f64 {
    format!("{v:.11e}").parse().unwrap_or(v)
}

/// `v` to 4 significant digits, as the report and the messages write numbers.
pub fn sig(v: f64) -> String {
    doe::fit::fmt_sig(v)
}

/// A symbol as a study writes it in ASCII (`mu_s`, `tau_c`, `e`) as the report prints it: a Greek
/// letter's name becomes the letter, `_x` a subscript where Unicode has one.
pub fn symbol(ascii: &str) -> String {
    const GREEK: &[(&str, &str)] = &[
        ("alpha", "α"),
        ("beta", "β"),
        ("gamma", "γ"),
        ("delta", "δ"),
        ("epsilon", "ε"),
        ("zeta", "ζ"),
        ("eta", "η"),
        ("theta", "θ"),
        ("kappa", "κ"),
        ("lambda", "λ"),
        ("mu", "μ"),
        ("nu", "ν"),
        ("xi", "ξ"),
        ("pi", "π"),
        ("rho", "ρ"),
        ("sigma", "σ"),
        ("tau", "τ"),
        ("phi", "φ"),
        ("chi", "χ"),
        ("psi", "ψ"),
        ("omega", "ω"),
    ];
    const SUB: &[(char, char)] = &[
        ('0', '₀'),
        ('1', '₁'),
        ('2', '₂'),
        ('3', '₃'),
        ('4', '₄'),
        ('5', '₅'),
        ('6', '₆'),
        ('7', '₇'),
        ('8', '₈'),
        ('9', '₉'),
        ('a', 'ₐ'),
        ('e', 'ₑ'),
        ('h', 'ₕ'),
        ('i', 'ᵢ'),
        ('j', 'ⱼ'),
        ('k', 'ₖ'),
        ('l', 'ₗ'),
        ('m', 'ₘ'),
        ('n', 'ₙ'),
        ('o', 'ₒ'),
        ('p', 'ₚ'),
        ('r', 'ᵣ'),
        ('s', 'ₛ'),
        ('t', 'ₜ'),
        ('u', 'ᵤ'),
        ('v', 'ᵥ'),
        ('x', 'ₓ'),
    ];
    let (base, sub) = match ascii.split_once('_') {
        Some((b, s)) => (b, Some(s)),
        None => (ascii, None),
    };
    let base = GREEK
        .iter()
        .find(|(n, _)| *n == base)
        .map_or(base.to_string(), |(_, g)| g.to_string());
    match sub {
        Some(s) => {
            let lowered: Option<String> = s
                .chars()
                .map(|c| SUB.iter().find(|(a, _)| *a == c).map(|(_, b)| *b))
                .collect();
            match lowered {
                Some(l) => format!("{base}{l}"),
                None => format!("{base}_{s}"),
            }
        }
        None => base,
    }
}

/// `name` with its first letter a capital, as a sentence names an executor (`slurm` → `Slurm`).
pub fn capitalised(name: &str) -> String {
    let mut c = name.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// A cell, a header or a key from a user's file as a one-line message shows it: line breaks
/// and control characters escaped (a quoted CSV cell or a JSON key may hold them) and at most 40
/// characters.
pub fn shown(s: &str) -> String {
    let one: String = s
        .chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_debug().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect();
    match one.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &one[..i]),
        None => one,
    }
}

/// Job ids in numeric order, each once, joined by commas.
pub fn job_list<'s>(ids: impl Iterator<Item = &'s str>) -> String {
    let set: BTreeSet<(usize, &str)> = ids.map(|i| (i.len(), i)).collect();
    set.into_iter()
        .map(|(_, i)| i)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where a report section puts its figures: numbered, captioned, written as SVG and PNG
/// (`report_figures::Figures`). A stage's section and the report's parts write through it.
pub trait FigureSink {
    /// A row of figures (file stem, SVG or why it could not be drawn, caption).
    fn row(&mut self, h: &mut String, items: Vec<(String, Result<String, String>, String)>);
}
