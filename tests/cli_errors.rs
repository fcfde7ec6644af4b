//! Malformed input: each case gives a one-line error naming the file (and
//! line), exit code 2, and no output file.

mod common;

use std::fs;
use std::path::{Path, PathBuf};

const OBJ: &str = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 10 10 0\nf 1 2 3\nf 2 4 3\n";
const WAYPOINTS: &str = "# px py pz nx ny nz\n1 1 0 0 0 1\n2 1 0 0 0 1\n3 1 0 0 0 1\n";

/// A valid two-layer toolpath folder `tp` in a fresh temp dir.
fn toolpath() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir_all(dir.path().join("tp/waypoint")).unwrap();
    fs::create_dir_all(dir.path().join("tp/layer")).unwrap();
    for k in ["0", "1"] {
        fs::write(dir.path().join(format!("tp/waypoint/{k}.txt")), WAYPOINTS).unwrap();
        fs::write(dir.path().join(format!("tp/layer/{k}.obj")), OBJ).unwrap();
    }
    dir
}

/// Run `maamplan check` with `args`; return (exit code, stderr, json written?).
fn check(dir: &Path, args: &[&str]) -> (i32, String, bool) {
    let json: PathBuf = dir.join("out.json");
    let out = common::maamplan()
        .arg("check")
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        common::stderr(&out),
        json.exists(),
    )
}

/// Assert a clean user error mentioning every `needle`.
fn assert_user_error(dir: &Path, args: &[&str], needles: &[&str]) {
    let (code, stderr, wrote) = check(dir, args);
    assert_eq!(code, 2, "exit code for {args:?}: stderr {stderr}");
    assert!(!wrote, "no output file may be written for {args:?}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line, got: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "'{n}' not in: {stderr}");
    }
}

fn tp_arg(dir: &tempfile::TempDir) -> String {
    dir.path().join("tp").display().to_string()
}

/// The valid toolpath with `file` (relative to its folder) holding
/// `text`, checked: a clean user error mentioning every `needle`.
fn assert_toolpath_error(file: &str, text: &str, needles: &[&str]) {
    let d = toolpath();
    fs::write(d.path().join("tp").join(file), text).unwrap();
    assert_user_error(d.path(), &[&tp_arg(&d)], needles);
}

/// The valid toolpath checked with `option` (`--head`, `--platform`)
/// naming the file `name` of `bytes` beside it (`None`: no such file): a
/// clean user error mentioning every `needle`.
fn assert_mesh_error(option: &str, name: &str, bytes: Option<&[u8]>, needles: &[&str]) {
    let d = toolpath();
    let mesh = d.path().join(name);
    if let Some(bytes) = bytes {
        fs::write(&mesh, bytes).unwrap();
    }
    let mesh = mesh.display().to_string();
    assert_user_error(d.path(), &[&tp_arg(&d), option, &mesh], needles);
}

#[test]
fn valid_toolpath_writes_json() {
    let d = toolpath();
    let (code, stderr, wrote) = check(d.path(), &[&tp_arg(&d)]);
    assert_eq!(code, 0, "{stderr}");
    assert!(wrote);
    let v = common::read_json(&d.path().join("out.json"));
    assert_eq!(v["waypoints"], 6);
    assert_eq!(v["backend"], "cpu");
    assert_eq!(v["layers"].as_array().unwrap().len(), 2);
    assert!(v["seconds"].as_f64().unwrap() >= 0.0);
    assert!(v["colliding"].as_u64().is_some());
}

#[test]
fn nan_field() {
    assert_toolpath_error(
        "waypoint/1.txt",
        "1 1 0 0 0 1\n2 nan 0 0 0 1\n",
        &["1.txt:2:", "field 2", "finite"],
    );
}

#[test]
fn non_numeric_field() {
    assert_toolpath_error(
        "waypoint/0.txt",
        "1 1 0 0 0 1\n\n1 1 x 0 0 1\n",
        &["0.txt:3:", "'x' is not a number"],
    );
}

#[test]
fn wrong_field_count() {
    assert_toolpath_error(
        "waypoint/0.txt",
        "1 1 0 0 0 1\n1 1 0 0 1\n",
        &["0.txt:2:", "expected 6 numbers", "found 5"],
    );
}

#[test]
fn zero_length_normal() {
    assert_toolpath_error(
        "waypoint/1.txt",
        "1 1 0 0 0 0\n",
        &["1.txt:1:", "zero-length nozzle direction"],
    );
}

#[test]
fn empty_layer() {
    assert_toolpath_error(
        "waypoint/1.txt",
        "# nothing here\n\n",
        &["1.txt", "empty layer"],
    );
}

#[test]
fn face_index_out_of_range() {
    assert_toolpath_error(
        "layer/1.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
        &["1.obj:5:", "face index 9 is out of range"],
    );
}

#[test]
fn face_with_two_vertices_in_obj() {
    // tobj reads `f 2 3` as a line and would drop it without a word.
    assert_toolpath_error(
        "layer/1.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3\n",
        &["1.obj:5:", "face has 2 vertices, needs at least 3"],
    );
}

#[test]
fn nan_vertex_in_obj() {
    assert_toolpath_error(
        "layer/0.obj",
        "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n",
        &["0.obj:2:", "finite"],
    );
}

#[test]
fn waypoint_layer_count_mismatch() {
    assert_toolpath_error(
        "waypoint/2.txt",
        WAYPOINTS,
        &["3 waypoint files but 2 layer files", "waypoint/2.txt"],
    );
}

#[test]
fn missing_toolpath() {
    let d = toolpath();
    let missing = d.path().join("nope").display().to_string();
    assert_user_error(d.path(), &[&missing], &["nope", "no such toolpath"]);
}

#[test]
fn unreadable_mesh() {
    assert_mesh_error(
        "--head",
        "head.obj",
        Some(&[0xff, 0xfe, 0x00, 0x80]),
        &["head.obj", "cannot read"],
    );
}

#[test]
fn missing_mesh() {
    assert_mesh_error(
        "--head",
        "head.obj",
        None,
        &["head.obj", "no such mesh file"],
    );
}

#[test]
fn unknown_mesh_format() {
    assert_mesh_error(
        "--head",
        "head.ply",
        Some(b"ply\n"),
        &["head.ply", "unknown mesh format"],
    );
}

#[test]
fn stl_ascii_nan() {
    assert_mesh_error(
        "--platform",
        "plate.stl",
        Some(b"solid p\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 inf\nvertex 0 1 0\nendloop\nendfacet\nendsolid p\n"),
        &["plate.stl:5:", "finite"],
    );
}

#[test]
fn stl_binary_truncated() {
    let mut bytes = vec![0u8; 80];
    bytes.extend(10u32.to_le_bytes()); // claims 10 facets, has none
    assert_mesh_error(
        "--platform",
        "bin.stl",
        Some(&bytes),
        &["bin.stl", "invalid STL"],
    );
}

/// (A head 10 mm across: the part is subdivided to an eighth of the head
/// beside the head's build, and a 1 mm head would have the part and the
/// platform cut into a great many pieces before the refusal.)
#[test]
fn open_head_is_refused() {
    assert_mesh_error(
        "--head",
        "open.obj",
        Some(b"v 0 0 0\nv 10 0 10\nv 0 10 10\nf 1 2 3\n"),
        &["not closed", "watertight"],
    );
}

#[test]
fn bad_place_argument() {
    let d = toolpath();
    let (code, stderr, wrote) = check(d.path(), &[&tp_arg(&d), "--place", "1,2"]);
    assert_eq!(code, 2);
    assert!(!wrote);
    assert!(stderr.contains("X,Y,Z"), "{stderr}");
}
