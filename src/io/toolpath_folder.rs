//! Toolpath folders in the zhang2021 layout (`waypoint/<k>.txt` and,
//! optionally, `layer/<k>.obj`, sorted naturally), read and written
//! ([`toolpath_files`]); a single file goes to [`super::waypoint_file`].
//! [`crate::toolpath`] is what they hold.
//!
//! A waypoint line is `px py pz nx ny nz` (spaces or commas); blank lines
//! and lines starting with `#` are skipped. Normals are normalised.

use super::mesh::load_mesh;
use super::output::FolderFile;
use super::waypoint_file::load_waypoint_file;
use super::waypoint_line::{is_comment_or_blank, split_fields, waypoint_of};
use super::{read_to_string, InputError, Placement};
use crate::toolpath::{Layer, Toolpath, Waypoint};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Load a toolpath folder or a single waypoint file
/// ([`load_waypoint_file`]).
pub fn load_toolpath(path: &Path, place: &Placement) -> Result<Toolpath, InputError> {
    if path.is_file() {
        return load_waypoint_file(path, place);
    }
    if !path.is_dir() {
        return Err(InputError::file(
            path,
            "no such toolpath: give a folder with waypoint/ (and layer/) or a waypoint file",
        ));
    }
    let wdir = path.join("waypoint");
    let ldir = path.join("layer");
    let waypoint_files = list_sorted(&wdir, &["txt"])?;
    if waypoint_files.is_empty() {
        return Err(InputError::file(
            &wdir,
            "no waypoint files (*.txt): a toolpath folder needs waypoint/<k>.txt per layer",
        ));
    }
    let layer_files = if ldir.is_dir() {
        list_sorted(&ldir, &["obj", "stl", "gltf", "glb"])?
    } else {
        Vec::new()
    };
    if !layer_files.is_empty() && layer_files.len() != waypoint_files.len() {
        let names: Vec<String> = layer_files.iter().map(|p| stem(p)).collect();
        let missing = waypoint_files
            .iter()
            .map(|p| stem(p))
            .find(|s| !names.contains(s))
            .map(|s| format!(" (no layer surface for waypoint/{s}.txt)"))
            .unwrap_or_default();
        return Err(InputError::file(
            path,
            format!(
                "{} waypoint files but {} layer files{missing}: every layer needs both waypoint/<k>.txt and layer/<k>.obj",
                waypoint_files.len(),
                layer_files.len()
            ),
        ));
    }
    // Layers are read in parallel; the first bad file in layer order is
    // the one reported, so errors are deterministic too.
    let layers: Vec<Result<Layer, InputError>> = waypoint_files
        .par_iter()
        .enumerate()
        .map(|(i, wfile)| {
            let name = stem(wfile);
            let surface = match layer_files.get(i) {
                Some(lfile) => {
                    if stem(lfile) != name {
                        return Err(InputError::file(
                            lfile,
                            format!("expected the layer surface for waypoint/{name}.txt here: name layer files like their waypoint files"),
                        ));
                    }
                    let m = load_mesh(lfile)?;
                    Some(m.map_vertices(|v| place.point(v)))
                }
                None => None,
            };
            Ok(Layer {
                waypoints: load_waypoints(wfile, place)?,
                name,
                surface,
            })
        })
        .collect();
    let layers = layers.into_iter().collect::<Result<Vec<_>, _>>()?;
    Ok(Toolpath { layers })
}

/// The columns of a waypoint line in the folder layout: `px py pz nx ny nz`.
const XYZ_NXNYNZ: [usize; 6] = [0, 1, 2, 3, 4, 5];

/// Parse one waypoint file.
pub fn load_waypoints(path: &Path, place: &Placement) -> Result<Vec<Waypoint>, InputError> {
    let text = read_to_string(path)?;
    parse_waypoints(path, &text, place)
}

/// Parse waypoint text (`path` only names the source in errors).
pub fn parse_waypoints(
    path: &Path,
    text: &str,
    place: &Placement,
) -> Result<Vec<Waypoint>, InputError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if is_comment_or_blank(line) {
            continue;
        }
        let (fields, count) = split_fields(line);
        if count != 6 {
            return Err(InputError::at(
                path,
                i + 1,
                format!(
                    "expected 6 numbers (px py pz nx ny nz), found {count}: fix or remove this line"
                ),
            ));
        }
        out.push(waypoint_of(path, i + 1, &fields, &XYZ_NXNYNZ, place)?);
    }
    if out.is_empty() {
        return Err(InputError::file(
            path,
            "empty layer (no waypoints): remove the file or add its waypoints",
        ));
    }
    Ok(out)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Files with one of `exts` in `dir`, sorted naturally: by leading number,
/// then by the rest of the name (`2 < 10 < 10S`).
fn list_sorted(dir: &Path, exts: &[&str]) -> Result<Vec<PathBuf>, InputError> {
    let rd = std::fs::read_dir(dir).map_err(|e| {
        InputError::file(
            dir,
            format!("cannot list the folder ({e}): check the toolpath layout"),
        )
    })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .map(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
                    .unwrap_or(false)
        })
        .collect();
    files.sort_by_cached_key(|p| natural_key(&stem(p)));
    Ok(files)
}

/// Sort key: (leading number or max, remainder).
pub fn natural_key(name: &str) -> (u64, String) {
    let digits: String = name.chars().take_while(|c| c.is_ascii_digit()).collect();
    let num = digits.parse().unwrap_or(u64::MAX);
    (num, name[digits.len()..].to_string())
}

/// The files of `tp` in the toolpath folder layout, relative to the folder:
/// `waypoint/<name>.txt` (one `px py pz nx ny nz` line per waypoint) and,
/// for layers with a surface, `layer/<name>.obj`. Numbers are written in
/// their shortest round-trip form, so reading the folder back gives the
/// same values.
pub fn toolpath_files(tp: &Toolpath) -> Vec<FolderFile> {
    use std::fmt::Write;
    let mut out = Vec::new();
    for l in &tp.layers {
        let mut text = String::with_capacity(l.waypoints.len() * 48);
        for w in &l.waypoints {
            let [x, y, z] = w.pos;
            let [a, b, c] = w.dir;
            let _ = writeln!(text, "{x} {y} {z} {a} {b} {c}");
        }
        out.push((
            PathBuf::from("waypoint").join(format!("{}.txt", l.name)),
            text.into_bytes(),
        ));
        if let Some(m) = &l.surface {
            out.push((
                PathBuf::from("layer").join(format!("{}.obj", l.name)),
                mesh_obj(m).into_bytes(),
            ));
        }
    }
    out
}

/// A mesh as OBJ text (`v` and 1-based `f` lines).
pub fn mesh_obj(m: &crate::geometry::Mesh) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(m.vertices.len() * 32 + m.triangles.len() * 24);
    for [x, y, z] in &m.vertices {
        let _ = writeln!(s, "v {x} {y} {z}");
    }
    for [a, b, c] in &m.triangles {
        let _ = writeln!(s, "f {} {} {}", a + 1, b + 1, c + 1);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order() {
        let mut v = vec!["10", "2", "1", "10S", "0"];
        v.sort_by_key(|s| natural_key(s));
        assert_eq!(v, vec!["0", "1", "2", "10", "10S"]);
    }

    #[test]
    fn parses_and_normalises() {
        let p = Placement {
            y_up: false,
            offset: [0.0, 0.0, 1.0],
        };
        let w = parse_waypoints(Path::new("x"), "# c\n1 2 3 0 0 2\n\n4,5,6,3,0,4\n", &p).unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!(w[0].pos, [1.0, 2.0, 4.0]);
        assert_eq!(w[0].dir, [0.0, 0.0, 1.0]);
        assert!((w[1].dir[0] - 0.6).abs() < 1e-6);
    }

    #[test]
    fn y_up_rotates() {
        let p = Placement {
            y_up: true,
            offset: [0.0; 3],
        };
        assert_eq!(p.direction([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
    }
}
