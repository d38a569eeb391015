//! Text mutations of scene and layout files for the property tests: delete or duplicate a
//! line, replace a number by an odd value, swap two keys, truncate, replace a quoted string.

use super::Rng;

pub const REPLACEMENTS: [&str; 16] = [
    "-1.0",
    "-0.0",
    "0",
    "1e308",
    "-1e308",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "\"abc\"",
    "[]",
    "true",
    "18446744073709551616",
    "-7",
    "[1.0, 2.0, 3.0, 4.0]",
    "{ a = 1 }",
];

/// Byte ranges of number tokens (a digit, or a sign before a digit, not inside a word).
fn number_tokens(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || ((b[i] == b'-' || b[i] == b'+') && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let in_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.');
        if starts && !in_word {
            let s = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || b"._eE+-".contains(&b[i])) {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

pub fn mutate(text: &str, rng: &mut Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    if lines.is_empty() {
        return text.to_string();
    }
    match rng.below(7) {
        0 => {
            let k = rng.below(lines.len());
            lines.remove(k);
        }
        1 => {
            let k = rng.below(lines.len());
            let l = lines[k].clone();
            lines.insert(k, l);
        }
        2 | 3 => {
            let joined = lines.join("\n");
            let toks = number_tokens(&joined);
            if toks.is_empty() {
                return joined;
            }
            let (s, e) = toks[rng.below(toks.len())];
            let r = REPLACEMENTS[rng.below(REPLACEMENTS.len())];
            return format!("{}{}{}", &joined[..s], r, &joined[e..]);
        }
        4 => {
            // swap the keys of two `key = value` lines
            let keyed: Vec<usize> = (0..lines.len())
                .filter(|&k| lines[k].contains(" = ") && !lines[k].trim_start().starts_with('#'))
                .collect();
            if keyed.is_empty() {
                return text.to_string();
            }
            let (a, b) = (keyed[rng.below(keyed.len())], keyed[rng.below(keyed.len())]);
            let (ka, va) = lines[a]
                .split_once(" = ")
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .unwrap();
            let (kb, vb) = lines[b]
                .split_once(" = ")
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .unwrap();
            lines[a] = format!("{kb} = {va}");
            lines[b] = format!("{ka} = {vb}");
        }
        5 => {
            let joined = lines.join("\n");
            let mut cut = rng.below(joined.len() + 1);
            while !joined.is_char_boundary(cut) {
                cut -= 1;
            }
            return joined[..cut].to_string();
        }
        _ => {
            // replace a quoted string value with an odd one
            let odd = ["", "é", "x+", "z-", "y", "water ", "∞", "fluid", "tank", "none"];
            let quoted: Vec<usize> = (0..lines.len()).filter(|&k| lines[k].contains('"')).collect();
            if quoted.is_empty() {
                return text.to_string();
            }
            let k = quoted[rng.below(quoted.len())];
            if let Some((head, rest)) = lines[k].split_once('"') {
                if let Some((_, tail)) = rest.split_once('"') {
                    lines[k] = format!("{head}\"{}\"{tail}", odd[rng.below(odd.len())]);
                }
            }
        }
    }
    lines.join("\n") + "\n"
}

/// `count` mutants of `base` (1–3 mutations each), deterministic in `seed`.
pub fn mutants(base: &str, count: usize, seed: u64) -> Vec<String> {
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| {
            let mut t = base.to_string();
            for _ in 0..1 + rng.below(3) {
                t = mutate(&t, &mut rng);
            }
            t
        })
        .collect()
}
