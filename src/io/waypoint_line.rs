//! One line of a waypoint file: its fields split, and the six numbers of
//! a waypoint (tip position, nozzle direction) read from the columns that
//! hold them. Shared by the toolpath folder's layer files and the single
//! waypoint files, so every format reports a bad number the same way.

use super::number::parse_f32;
use super::{InputError, Placement};
use crate::toolpath::Waypoint;
use std::path::Path;

/// The fields a line holds at most before the rest only counts: no list
/// is allocated per line.
pub const MAX_FIELDS: usize = 32;

/// A line's fields, separated by whitespace or commas (empty fields
/// between two commas are not fields), and how many there are (which may
/// exceed the [`MAX_FIELDS`] kept).
pub fn split_fields(line: &str) -> ([&str; MAX_FIELDS], usize) {
    let mut fields = [""; MAX_FIELDS];
    let mut count = 0;
    for f in line
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
    {
        if count < MAX_FIELDS {
            fields[count] = f;
        }
        count += 1;
    }
    (fields, count)
}

/// Is the line blank or a `#` comment (not a waypoint)?
pub fn is_comment_or_blank(line: &str) -> bool {
    let line = line.trim();
    line.is_empty() || line.starts_with('#')
}

/// The waypoint of `fields` whose columns `cols` hold `px py pz nx ny
/// nz` (0-based), placed; `line` (1-based) names it in errors. The nozzle
/// direction is normalised.
pub fn waypoint_of(
    path: &Path,
    line: usize,
    fields: &[&str],
    cols: &[usize; 6],
    place: &Placement,
) -> Result<Waypoint, InputError> {
    let mut v = [0f32; 6];
    for (k, &c) in cols.iter().enumerate() {
        let f = fields[c];
        let x = parse_f32(f.as_bytes()).ok_or_else(|| {
            InputError::at(
                path,
                line,
                format!("field {} '{f}' is not a number: fix this line", c + 1),
            )
        })?;
        if !x.is_finite() {
            return Err(InputError::at(
                path,
                line,
                format!(
                    "field {} is {f}: every coordinate must be a finite number",
                    c + 1
                ),
            ));
        }
        v[k] = x;
    }
    let len = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt();
    if len.is_nan() || len <= 1e-12 {
        return Err(InputError::at(
            path,
            line,
            "zero-length nozzle direction (nx ny nz): give the direction from the tip into the head",
        ));
    }
    Ok(Waypoint {
        pos: place.point([v[0], v[1], v[2]]),
        dir: place.direction([v[3] / len, v[4] / len, v[5] / len]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_split_on_spaces_and_commas() {
        let (f, n) = split_fields(" 1, 2\t3 ,,4 ");
        assert_eq!(n, 4);
        assert_eq!(&f[..4], &["1", "2", "3", "4"]);
        let many = vec!["1"; 40].join(" ");
        assert_eq!(split_fields(&many).1, 40);
    }

    #[test]
    fn columns_pick_the_numbers() {
        let p = Placement::default();
        let fields = ["0", "0", "2", "a", "1", "3", "0"];
        let w = waypoint_of(Path::new("f"), 1, &fields, &[4, 5, 6, 0, 1, 2], &p).unwrap();
        assert_eq!(w.pos, [1.0, 3.0, 0.0]);
        assert_eq!(w.dir, [0.0, 0.0, 1.0]);
        let e = waypoint_of(Path::new("f"), 7, &fields, &[3, 4, 5, 0, 1, 2], &p).unwrap_err();
        assert!(e.to_string().contains("f:7: field 4 'a'"), "{e}");
    }
}
