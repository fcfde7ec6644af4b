//! The header of a waypoint CSV: a first line that names the columns
//! (`x y z nx ny nz` in any order, optionally `layer`; `px py pz` for
//! `x y z` too; comma- or whitespace-separated, names in any case, other
//! columns ignored), read into the [`Layout`] every later line follows.

use super::number::parse_f32;
use super::waypoint_line::split_fields;
use super::InputError;
use std::path::Path;

/// Where a single waypoint file's lines keep what they hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// The columns (0-based) of `px py pz nx ny nz`.
    pub cols: [usize; 6],
    /// The column naming each waypoint's layer, if any.
    pub layer: Option<usize>,
    /// Fields every line has.
    pub fields: usize,
    /// The line (1-based) of the header that named them; `None`: a plain
    /// file, the fields in the order `px py pz nx ny nz [layer]`.
    pub header: Option<usize>,
}

/// The names a header may give each of the six waypoint columns, in the
/// order of [`Layout::cols`].
const NAMES: [&[&str]; 6] = [
    &["x", "px"],
    &["y", "py"],
    &["z", "pz"],
    &["nx"],
    &["ny"],
    &["nz"],
];

/// The layout of `line` (1-based `n`) if it is a header: none of its
/// fields is a number. `None`: a line of numbers (a plain file).
pub fn header_layout(path: &Path, n: usize, line: &str) -> Result<Option<Layout>, InputError> {
    let (fields, count) = split_fields(line);
    let names = &fields[..count.min(fields.len())];
    if names.iter().any(|f| parse_f32(f.as_bytes()).is_some()) {
        return Ok(None);
    }
    if count > fields.len() {
        return Err(InputError::at(
            path,
            n,
            format!(
                "the header names {count} columns, more than the {} a waypoint file may have: keep x y z nx ny nz (and layer)",
                fields.len()
            ),
        ));
    }
    let mut cols = [usize::MAX; 6];
    let mut layer = None;
    for (c, raw) in names.iter().enumerate() {
        let name = raw
            .trim_matches(|q| q == '"' || q == '\'')
            .to_ascii_lowercase();
        let slot = if name == "layer" {
            &mut layer
        } else if let Some(k) = NAMES
            .iter()
            .position(|alias| alias.contains(&name.as_str()))
        {
            if cols[k] != usize::MAX {
                return Err(duplicate(path, n, raw));
            }
            cols[k] = c;
            continue;
        } else {
            continue;
        };
        if slot.is_some() {
            return Err(duplicate(path, n, raw));
        }
        *slot = Some(c);
    }
    let missing: Vec<&str> = NAMES
        .iter()
        .zip(cols)
        .filter(|(_, c)| *c == usize::MAX)
        .map(|(alias, _)| alias[0])
        .collect();
    if !missing.is_empty() {
        return Err(InputError::at(
            path,
            n,
            format!(
                "the header names no column {}: name the columns x y z nx ny nz (any order, optionally layer)",
                missing.join(", ")
            ),
        ));
    }
    Ok(Some(Layout {
        cols,
        layer,
        fields: count,
        header: Some(n),
    }))
}

fn duplicate(path: &Path, n: usize, name: &str) -> InputError {
    InputError::at(
        path,
        n,
        format!("the header names the column '{name}' twice: keep one"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(line: &str) -> Result<Option<Layout>, InputError> {
        header_layout(Path::new("w.csv"), 1, line)
    }

    #[test]
    fn names_in_any_order_and_case() {
        let l = layout("NZ, nx ,Layer,speed,\"Y\",x,ny,z").unwrap().unwrap();
        assert_eq!(l.cols, [5, 4, 7, 1, 6, 0]);
        assert_eq!((l.layer, l.fields, l.header), (Some(2), 8, Some(1)));
        let l = layout("px py pz nx ny nz").unwrap().unwrap();
        assert_eq!((l.cols, l.layer), ([0, 1, 2, 3, 4, 5], None));
    }

    #[test]
    fn numbers_are_not_a_header() {
        assert_eq!(layout("1 2 3 0 0 1").unwrap(), None);
        assert_eq!(layout("x 2 3 0 0 1").unwrap(), None);
    }

    #[test]
    fn missing_and_repeated_columns_are_refused() {
        let e = layout("x y z nx ny").unwrap_err().to_string();
        assert!(e.contains("w.csv:1:") && e.contains("no column nz"), "{e}");
        let e = layout("x y z nx ny nz X").unwrap_err().to_string();
        assert!(e.contains("'X' twice"), "{e}");
    }
}
