//! A single waypoint file: the whole toolpath in one file, in print order.
//! Its lines are `px py pz nx ny nz` (spaces or commas, `#` comments), or
//! the columns a CSV header names ([`super::waypoint_csv`]). Its layers
//! come from a layer column (a seventh field, or the header's `layer`:
//! consecutive waypoints of the same value are one layer, named by it), or
//! else from blank lines between them. A file with neither is one layer
//! without a surface, whose layers the job finds from how its beads stack
//! ([`crate::job::stacked`]).

use super::read_to_string;
use super::waypoint_csv::{header_layout, Layout};
use super::waypoint_line::{is_comment_or_blank, split_fields, waypoint_of};
use super::{InputError, Placement};
use crate::toolpath::{Layer, Toolpath};
use rustc_hash::FxHashMap;
use std::path::Path;

/// Read a single waypoint file.
pub fn load_waypoint_file(path: &Path, place: &Placement) -> Result<Toolpath, InputError> {
    let text = read_to_string(path)?;
    parse_waypoint_file(path, &text, place)
}

/// Parse the text of a single waypoint file (`path` names it in errors
/// and, where the file holds one layer, names that layer).
pub fn parse_waypoint_file(
    path: &Path,
    text: &str,
    place: &Placement,
) -> Result<Toolpath, InputError> {
    let mut layout: Option<Layout> = None;
    let mut layers = Layers::default();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        if line.trim().is_empty() {
            layers.blank = true;
            continue;
        }
        if is_comment_or_blank(line) {
            continue;
        }
        let layout = match layout {
            Some(l) => l,
            None => {
                let found = match header_layout(path, n, line)? {
                    Some(header) => {
                        layout = Some(header);
                        continue;
                    }
                    None => plain_layout(path, n, line)?,
                };
                *layout.insert(found)
            }
        };
        let (fields, count) = split_fields(line);
        if count != layout.fields {
            return Err(field_count(path, n, count, &layout));
        }
        let w = waypoint_of(path, n, &fields, &layout.cols, place)?;
        match layout.layer {
            Some(c) => layers.named(path, n, fields[c])?,
            None => layers.unnamed(),
        }
        layers.list.last_mut().expect("a layer").waypoints.push(w);
    }
    if layers.list.is_empty() {
        return Err(InputError::file(
            path,
            "no waypoints: give one line per waypoint, px py pz nx ny nz",
        ));
    }
    let mut list = layers.list;
    if list.len() == 1 && layout.and_then(|l| l.layer).is_none() {
        list[0].name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
    }
    Ok(Toolpath { layers: list })
}

/// The layout of a plain file, from its first waypoint line (1-based `n`):
/// six numbers, or seven with the layer last.
fn plain_layout(path: &Path, n: usize, line: &str) -> Result<Layout, InputError> {
    let (_, count) = split_fields(line);
    if count != 6 && count != 7 {
        return Err(InputError::at(
            path,
            n,
            format!("expected 6 numbers (px py pz nx ny nz), or 7 with the layer last, found {count}: fix or remove this line"),
        ));
    }
    Ok(Layout {
        cols: [0, 1, 2, 3, 4, 5],
        layer: (count == 7).then_some(6),
        fields: count,
        header: None,
    })
}

/// A line with other than the layout's field count.
fn field_count(path: &Path, n: usize, count: usize, layout: &Layout) -> InputError {
    let msg = match (layout.header, layout.layer) {
        (Some(h), _) => format!(
            "expected {} fields, as the header at line {h} names, found {count}: fix this line",
            layout.fields
        ),
        (None, Some(_)) => format!(
            "expected 7 fields (px py pz nx ny nz layer) as on the first waypoint line, found {count}: give every line its layer"
        ),
        (None, None) => format!(
            "expected 6 numbers (px py pz nx ny nz) as on the first waypoint line, found {count}: give every line a layer or none"
        ),
    };
    InputError::at(path, n, msg)
}

/// The layers read so far.
#[derive(Default)]
struct Layers {
    list: Vec<Layer>,
    /// A blank line since the last waypoint.
    blank: bool,
    /// Each layer name seen, with the line where its layer began.
    began: FxHashMap<String, usize>,
}

impl Layers {
    /// The next waypoint belongs to the layer named `name` (line `n`).
    fn named(&mut self, path: &Path, n: usize, name: &str) -> Result<(), InputError> {
        let name = name.trim_matches(|q| q == '"' || q == '\'');
        let current = self.list.last().map(|l| l.name.as_str());
        if current == Some(name) {
            return Ok(());
        }
        if let Some(first) = self.began.get(name) {
            return Err(InputError::at(
                path,
                n,
                format!(
                    "layer '{name}' again after layer '{}' (it began at line {first}): a layer's waypoints must be consecutive, in print order",
                    current.unwrap_or_default()
                ),
            ));
        }
        self.began.insert(name.to_string(), n);
        self.push(name.to_string());
        Ok(())
    }

    /// The next waypoint has no layer name: a blank line before it starts
    /// the next layer.
    fn unnamed(&mut self) {
        if self.list.is_empty() || std::mem::take(&mut self.blank) {
            self.push(self.list.len().to_string());
        }
    }

    fn push(&mut self, name: String) {
        self.blank = false;
        self.list.push(Layer {
            name,
            waypoints: Vec::new(),
            surface: None,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Toolpath, InputError> {
        parse_waypoint_file(Path::new("dir/path.txt"), text, &Placement::default())
    }

    fn shape(tp: &Toolpath) -> Vec<(String, usize)> {
        tp.layers
            .iter()
            .map(|l| (l.name.clone(), l.waypoints.len()))
            .collect()
    }

    #[test]
    fn no_layer_information_is_one_layer_named_after_the_file() {
        let tp = parse("\n# c\n1 0 0 0 0 1\n2 0 0 0 0 1\n\n").unwrap();
        assert_eq!(shape(&tp), vec![("path".into(), 2)]);
    }

    #[test]
    fn blank_lines_separate_layers() {
        let tp = parse("1 0 0 0 0 1\n2 0 0 0 0 1\n\n\n# layer 1\n1 0 1 0 0 1\n").unwrap();
        assert_eq!(shape(&tp), vec![("0".into(), 2), ("1".into(), 1)]);
    }

    #[test]
    fn a_seventh_column_names_the_layers() {
        let tp = parse("1 0 0 0 0 1 a\n\n2 0 0 0 0 1 a\n1 0 1 0 0 1 2S\n").unwrap();
        assert_eq!(shape(&tp), vec![("a".into(), 2), ("2S".into(), 1)]);
        assert!(tp.layers[1].is_support());
        let e = parse("1 0 0 0 0 1 0\n1 0 1 0 0 1 1\n1 0 2 0 0 1 0\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("path.txt:3: layer '0' again after layer '1' (it began at line 1)"),
            "{e}"
        );
        let e = parse("1 0 0 0 0 1 0\n1 0 1 0 0 1\n").unwrap_err();
        assert!(
            e.to_string().contains("path.txt:2: expected 7 fields"),
            "{e}"
        );
    }

    #[test]
    fn a_header_names_the_columns() {
        let text = "# from a slicer\nLayer;x,Y z nz ny nx speed\n0 1 2 3 1 0 0 9\n0 4 5 6 1 0 0 9\n1 7 8 9 0 3 4 9\n";
        let e = parse(text).unwrap_err();
        assert!(
            e.to_string()
                .contains("path.txt:2: the header names no column"),
            "{e}"
        );
        let tp = parse(&text.replace(';', ",")).unwrap();
        assert_eq!(shape(&tp), vec![("0".into(), 2), ("1".into(), 1)]);
        assert_eq!(tp.layers[0].waypoints[1].pos, [4.0, 5.0, 6.0]);
        assert_eq!(tp.layers[1].waypoints[0].dir, [0.8, 0.6, 0.0]);
        let e = parse("x y z nx ny nz\n1 2 3 0 0 1 5\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("path.txt:2: expected 6 fields, as the header at line 1 names, found 7"),
            "{e}"
        );
    }

    #[test]
    fn bad_lines_are_named() {
        let e = parse("1 0 0 0 0 1\n1 0 0 0 0\n").unwrap_err();
        assert!(
            e.to_string().contains("path.txt:2: expected 6 numbers"),
            "{e}"
        );
        let e = parse("1 0 0 0 0\n").unwrap_err();
        assert!(
            e.to_string().contains("path.txt:1: expected 6 numbers"),
            "{e}"
        );
        let e = parse("# only\n\n").unwrap_err();
        assert!(e.to_string().contains("path.txt: no waypoints"), "{e}");
    }
}
