//! Mesh loading by extension: OBJ (`tobj`; plain files by
//! [`super::obj_plain`], to the same mesh), STL ASCII and binary
//! (`stl_io`), glTF/GLB (`gltf`, every triangle primitive with its node
//! transform). Non-finite coordinates, bad indices and empty meshes are
//! errors that name the file and, for text formats, the line.

use super::{read_to_string, InputError};
use crate::geometry::Mesh;
use glam::{Mat4, Vec3};
use std::path::Path;

/// Load a triangle mesh from `.obj`, `.stl`, `.gltf` or `.glb`.
pub fn load_mesh(path: &Path) -> Result<Mesh, InputError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !path.is_file() {
        return Err(InputError::file(path, "no such mesh file: check the path"));
    }
    let mesh = match ext.as_str() {
        "obj" => load_obj(path)?,
        "stl" => load_stl(path)?,
        "gltf" | "glb" => load_gltf(path)?,
        _ => {
            return Err(InputError::file(
                path,
                "unknown mesh format: use .obj, .stl, .gltf or .glb",
            ))
        }
    };
    if mesh.triangles.is_empty() {
        return Err(InputError::file(
            path,
            "the mesh has no triangles: export it with its faces",
        ));
    }
    Ok(mesh)
}

/// OBJ: parsed by `tobj`; when it refuses the file, yields a coordinate
/// that is not finite or would drop a face of fewer than three vertices
/// (tobj reads `f 1 2` as a line), the line-level check finds the line to
/// name. The check runs only on files tobj refuses, so a valid file's
/// numbers are parsed once.
fn load_obj(path: &Path) -> Result<Mesh, InputError> {
    let text = read_to_string(path)?;
    // Plain files (every layer surface of the data set) are read in one
    // pass into the mesh tobj would make; the rest go through tobj.
    let read = match super::obj_plain::parse(&text) {
        Some(mesh) => Ok(mesh),
        None => {
            if has_short_face(&text) {
                check_obj(path, &text)?;
            }
            read_with_tobj(&text)
        }
    };
    match read {
        Ok(mesh) if mesh.vertices.iter().flatten().all(|x| x.is_finite()) => Ok(mesh),
        Ok(_) => {
            check_obj(path, &text)?;
            Err(InputError::file(
                path,
                "a vertex coordinate is not a finite number: re-export the mesh",
            ))
        }
        Err(e) => {
            check_obj(path, &text)?;
            Err(InputError::file(
                path,
                format!("invalid OBJ ({e}): re-export the mesh"),
            ))
        }
    }
}

/// The mesh `tobj` reads from OBJ `text` (triangulated, every object's
/// faces in one mesh); the reference [`super::obj_plain`] is tested
/// against.
pub fn read_with_tobj(text: &str) -> Result<Mesh, tobj::LoadError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Err(tobj::LoadError::GenericFailure)
    })?;
    let mut mesh = Mesh::default();
    for m in models {
        let base = mesh.vertices.len() as u32;
        mesh.vertices
            .extend(m.mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        mesh.triangles.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|c| [base + c[0], base + c[1], base + c[2]]),
        );
    }
    Ok(mesh)
}

/// Is there an `f` statement with fewer than three vertex references?
/// (Counts tokens only: no number is parsed.)
fn has_short_face(text: &str) -> bool {
    text.lines().any(|l| {
        let mut it = l.split_ascii_whitespace();
        it.next() == Some("f") && it.take(3).count() < 3
    })
}

/// Line-level validation of the OBJ statements we use (`v`, `f`).
fn check_obj(path: &Path, text: &str) -> Result<(), InputError> {
    let vertex_count = text
        .lines()
        .filter(|l| l.trim_start().starts_with("v "))
        .count() as i64;
    let mut seen = 0i64;
    for (i, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        let checked = match it.next() {
            Some("v") => {
                seen += 1;
                check_vertex(it.collect())
            }
            Some("f") => check_face(it.collect(), seen, vertex_count),
            _ => Ok(()),
        };
        checked.map_err(|msg| InputError::at(path, i + 1, msg))?;
    }
    Ok(())
}

/// A `v` statement's coordinates: at least three, the first three finite
/// numbers.
fn check_vertex(vals: Vec<&str>) -> Result<(), String> {
    if vals.len() < 3 {
        return Err(format!(
            "vertex has {} coordinates, needs 3: fix this line",
            vals.len()
        ));
    }
    for v in &vals[..3] {
        match v.parse::<f32>() {
            Ok(x) if x.is_finite() => {}
            Ok(_) => {
                return Err(format!(
                    "vertex coordinate {v}: every coordinate must be a finite number"
                ))
            }
            Err(_) => {
                return Err(format!(
                    "vertex coordinate '{v}' is not a number: fix this line"
                ))
            }
        }
    }
    Ok(())
}

/// An `f` statement's vertex references: at least three, each naming one
/// of the file's `vertex_count` vertices (a negative one counts back from
/// the `seen` so far).
fn check_face(refs: Vec<&str>, seen: i64, vertex_count: i64) -> Result<(), String> {
    if refs.len() < 3 {
        return Err(format!(
            "face has {} vertices, needs at least 3: fix this line",
            refs.len()
        ));
    }
    for r in refs {
        let idx = r.split('/').next().unwrap_or("");
        let k: i64 = idx
            .parse()
            .map_err(|_| format!("face index '{r}' is not an integer: fix this line"))?;
        let resolved = if k < 0 { seen + k + 1 } else { k };
        if k == 0 || resolved < 1 || resolved > vertex_count {
            return Err(format!("face index {k} is out of range (the file has {vertex_count} vertices): fix the face or add the vertex"));
        }
    }
    Ok(())
}

fn load_stl(path: &Path) -> Result<Mesh, InputError> {
    let bytes = std::fs::read(path).map_err(|e| {
        InputError::file(
            path,
            format!("cannot read the file ({e}): check the path and permissions"),
        )
    })?;
    let ascii = bytes.trim_ascii_start().starts_with(b"solid")
        && std::str::from_utf8(&bytes)
            .map(|t| t.contains("facet"))
            .unwrap_or(false);
    if ascii {
        // Locate bad numbers by line before stl_io parses.
        let text = String::from_utf8_lossy(&bytes);
        for (i, line) in text.lines().enumerate() {
            let mut it = line.split_whitespace();
            if it.next() == Some("vertex") {
                let vals: Vec<&str> = it.collect();
                if vals.len() != 3 {
                    return Err(InputError::at(
                        path,
                        i + 1,
                        format!(
                            "vertex has {} coordinates, needs 3: fix this line",
                            vals.len()
                        ),
                    ));
                }
                for v in vals {
                    match v.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        _ => {
                            return Err(InputError::at(
                                path,
                                i + 1,
                                format!(
                                    "vertex coordinate '{v}' is not a finite number: fix this line"
                                ),
                            ))
                        }
                    }
                }
            }
        }
    }
    let mut cursor = std::io::Cursor::new(&bytes);
    let stl = stl_io::read_stl(&mut cursor)
        .map_err(|e| InputError::file(path, format!("invalid STL ({e}): re-export the mesh")))?;
    let vertices: Vec<[f32; 3]> = stl.vertices.iter().map(|v| [v[0], v[1], v[2]]).collect();
    if let Some(i) = vertices
        .iter()
        .position(|v| v.iter().any(|c| !c.is_finite()))
    {
        return Err(InputError::file(
            path,
            format!("vertex {i} has a non-finite coordinate: re-export the mesh"),
        ));
    }
    let triangles = stl
        .faces
        .iter()
        .map(|f| {
            [
                f.vertices[0] as u32,
                f.vertices[1] as u32,
                f.vertices[2] as u32,
            ]
        })
        .collect();
    Ok(Mesh {
        vertices,
        triangles,
    })
}

fn load_gltf(path: &Path) -> Result<Mesh, InputError> {
    let (doc, buffers, _) = gltf::import(path)
        .map_err(|e| InputError::file(path, format!("invalid glTF ({e}): re-export the mesh")))?;
    let mut mesh = Mesh::default();
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let mut stack: Vec<(gltf::Node, Mat4)> = match &scene {
        Some(s) => s.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
        None => Vec::new(),
    };
    while let Some((node, parent)) = stack.pop() {
        // Column-major, as glTF stores it.
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(gm) = node.mesh() {
            for prim in gm.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let Some(pos) = reader.read_positions() else {
                    continue;
                };
                let base = mesh.vertices.len() as u32;
                for p in pos {
                    let q = m.transform_point3(Vec3::from(p)).to_array();
                    if q.iter().any(|c| !c.is_finite()) {
                        return Err(InputError::file(
                            path,
                            format!(
                                "mesh {} has a non-finite vertex: re-export the mesh",
                                gm.index()
                            ),
                        ));
                    }
                    mesh.vertices.push(q);
                }
                let count = mesh.vertices.len() as u32 - base;
                let idx: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..count).collect(),
                };
                for t in idx.chunks_exact(3) {
                    if t.iter().any(|&i| i >= count) {
                        return Err(InputError::file(
                            path,
                            format!(
                                "mesh {} has a face index out of range: re-export the mesh",
                                gm.index()
                            ),
                        ));
                    }
                    mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
                }
            }
        }
        stack.extend(node.children().map(|c| (c, m)));
    }
    Ok(mesh)
}
