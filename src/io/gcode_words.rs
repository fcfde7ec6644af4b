//! The words of one G-code line, as controllers read them: letters each
//! followed by a number, separated by spaces or run together
//! (`G1X1.5Y2`), any number of `G`/`M` codes on a line (`G21 G40 G49 G80`,
//! `T1 M6`), `;` and `( )` comments, a leading `N` line number, `%` lines
//! (a program's start and end on tape-era controllers). Whether a
//! comment marks a layer change (`;LAYER:3`, `;LAYER_CHANGE`, `; layer 3`)
//! is kept: it is the only word of a program on where its layers begin.

use std::borrow::Cow;

/// One line's words.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LineWords {
    /// `G` and `M` codes, canonical (`G1` for `G01`, `G43.4`, `M6` for
    /// `M06`), and `TRAORI` / `TRAFOOF`, in the line's order.
    pub codes: Vec<String>,
    /// Every other word, upper-cased letter and value, in order (`T` among
    /// them: whether it changes the tool depends on the line's codes).
    pub values: Vec<(char, f64)>,
    /// A comment on the line marks a layer change.
    pub layer_change: bool,
}

impl LineWords {
    /// Nothing but comments (or nothing at all).
    pub fn is_empty(&self) -> bool {
        self.codes.is_empty() && self.values.is_empty()
    }
}

/// Does a comment's text (without its `;` or parentheses) mark a layer
/// change? `LAYER:<n>` (Cura), `LAYER_CHANGE` (PrusaSlicer, OrcaSlicer),
/// `LAYER <n>` (Simplify3D, `; layer 3, Z = 0.6`), in any case; not
/// `LAYER_COUNT:<n>` and the like, which describe the program.
pub fn is_layer_change(comment: &str) -> bool {
    let c = comment.trim().to_ascii_uppercase();
    let number_follows = |rest: &str| {
        let rest = rest.trim_start();
        let rest = rest.strip_prefix('-').unwrap_or(rest);
        rest.starts_with(|ch: char| ch.is_ascii_digit())
    };
    c == "LAYER_CHANGE"
        || c.strip_prefix("LAYER:").is_some_and(number_follows)
        || c.strip_prefix("LAYER ").is_some_and(number_follows)
}

/// The words of line `raw`; an error names the piece that is not a
/// letter followed by a finite number. A line without comments is read
/// in place: a program's motion lines cost no allocation but their
/// words'.
pub fn line_words(raw: &str) -> Result<LineWords, String> {
    let mut out = LineWords::default();
    let text: Cow<str> = if raw.contains([';', '(']) {
        Cow::Owned(outside_comments(raw, &mut out.layer_change))
    } else {
        Cow::Borrowed(raw)
    };
    let trimmed = text.trim();
    // `%` marks the start and end of a program on tape-era controllers.
    if trimmed == "%" {
        return Ok(out);
    }
    if let Some(code) = ["TRAORI", "TRAFOOF"]
        .into_iter()
        .find(|c| trimmed.eq_ignore_ascii_case(c))
    {
        out.codes.push(code.to_string());
        return Ok(out);
    }
    let mut first = true;
    for token in text.split_whitespace() {
        let bad = || format!("'{token}' is not a letter and a finite number");
        for word in split_words(token) {
            let (letter, num) = word.ok_or_else(bad)?;
            let x: f64 = num
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite())
                .ok_or_else(bad)?;
            let leading_n = std::mem::take(&mut first) && letter == 'N';
            match letter {
                _ if leading_n => {}
                'G' | 'M' => out.codes.push(format!("{letter}{x}")),
                _ => out.values.push((letter, x)),
            }
        }
    }
    Ok(out)
}

/// The text of line `raw` outside its `;` and `( )` comments; a comment
/// that marks a layer change sets `layer_change`.
fn outside_comments(raw: &str, layer_change: &mut bool) -> String {
    let mut text = String::with_capacity(raw.len());
    let mut comment = String::new();
    let mut depth = 0;
    for (i, ch) in raw.char_indices() {
        match ch {
            ';' if depth == 0 => {
                *layer_change |= is_layer_change(&raw[i + 1..]);
                break;
            }
            '(' => {
                depth += 1;
                comment.clear();
            }
            ')' if depth > 0 => {
                depth -= 1;
                *layer_change |= depth == 0 && is_layer_change(&comment);
            }
            _ if depth == 0 => text.push(ch),
            _ => comment.push(ch),
        }
    }
    text
}

/// A whitespace-separated token's words: `X1.5`, or run together as many
/// controllers accept them (`G1X1.5Y2`), each an upper-cased letter and
/// the number after it. `None` for a piece that is not a letter followed
/// by a number (the token is then not words at all).
fn split_words(token: &str) -> impl Iterator<Item = Option<(char, &str)>> + '_ {
    let b = token.as_bytes();
    let mut i = 0;
    std::iter::from_fn(move || {
        if i >= b.len() {
            return None;
        }
        if !b[i].is_ascii_alphabetic() {
            i = b.len();
            return Some(None);
        }
        // A letter is one byte, never inside a longer character: the
        // slices fall on character boundaries.
        let end = (i + 1..b.len())
            .find(|&k| b[k].is_ascii_alphabetic())
            .unwrap_or(b.len());
        let word = (end > i + 1).then(|| (b[i].to_ascii_uppercase() as char, &token[i + 1..end]));
        i = end;
        Some(word)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(codes: &[&str], values: &[(char, f64)]) -> LineWords {
        LineWords {
            codes: codes.iter().map(|c| c.to_string()).collect(),
            values: values.to_vec(),
            layer_change: false,
        }
    }

    #[test]
    fn words_are_read_with_or_without_spaces_and_comments_go() {
        let r = |s: &str| line_words(s).unwrap();
        let g1 = w(&["G1"], &[('X', 1.5), ('Y', -2.0), ('E', 0.25)]);
        assert_eq!(r("G1 X1.5 Y-2 E0.25"), g1);
        assert_eq!(r("g01x1.5y-2e.25 ; comment"), g1);
        assert_eq!(r("N120 G1 X1.5 (note) Y-2 E0.25"), g1);
        assert_eq!(r("G43.4 H1"), w(&["G43.4"], &[('H', 1.0)]));
        assert_eq!(r(" TRAORI "), w(&["TRAORI"], &[]));
        assert!(r("; only a comment").is_empty());
        assert!(r("%").is_empty() && r(" % (start)").is_empty());
        // Several codes on a line, and a tool with its change.
        assert_eq!(r("G21 G40 G49 G80"), w(&["G21", "G40", "G49", "G80"], &[]));
        assert_eq!(r("T1 M06"), w(&["M6"], &[('T', 1.0)]));
        // No exponents in G-code: E starts the next word.
        assert_eq!(r("G1 X1E5"), w(&["G1"], &[('X', 1.0), ('E', 5.0)]));
        for bad in ["G1 XNaN", "G1 X1e", "G1 X", "G1 *5", "G1 X1..2", "G1 Xinf"] {
            assert!(line_words(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn layer_change_comments_are_recognised_and_others_are_not() {
        for yes in [
            ";LAYER:3",
            ";LAYER:-1",
            "; layer 3, Z = 0.6",
            ";LAYER_CHANGE",
            "G1 X1 ; LAYER:12",
            "(LAYER 4)",
        ] {
            assert!(line_words(yes).unwrap().layer_change, "{yes}");
        }
        for no in [
            ";LAYER_COUNT:20",
            ";LAYER_HEIGHT:0.2",
            "; layers: 20",
            "G1 X1",
            ";Z:0.2",
        ] {
            assert!(!line_words(no).unwrap().layer_change, "{no}");
        }
    }
}
