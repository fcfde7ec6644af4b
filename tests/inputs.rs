//! Toolpaths without layer surfaces, in every format `plan` reads: a
//! `waypoint/` folder without `layer/`, a single file whose layers are
//! separated by blank lines or named by a seventh column, a CSV whose
//! header names its columns, and a single file without layers. Each is
//! written here, read back (layers and waypoints), and planned end to end
//! with the part modelled from its beads; and a run with no part model
//! says that only the platform was checked.

mod common;

use maamplan::io::toolpath_folder::load_toolpath;
use maamplan::io::Placement;
use maamplan::toolpath::Toolpath;
use std::fmt::Write;
use std::fs;
use std::path::{Path, PathBuf};

/// Waypoints of layer `k` of the tiny part: a 10 mm line of 21 points,
/// each layer half a millimetre above the last, printed back and forth,
/// nozzles up.
fn line(k: usize) -> Vec<[f32; 6]> {
    (0..21)
        .map(|i| {
            let i = if k.is_multiple_of(2) { i } else { 20 - i };
            [i as f32 * 0.5 - 5.0, 0.0, k as f32 * 0.5, 0.0, 0.0, 1.0]
        })
        .collect()
}

/// Layer `k` as text, each line `px py pz nx ny nz` joined by `sep`,
/// then `suffix` (a layer column).
fn layer_text(k: usize, sep: &str, suffix: &str) -> String {
    let mut t = String::new();
    for w in line(k) {
        let fields: Vec<String> = w.iter().map(|x| x.to_string()).collect();
        let _ = writeln!(t, "{}{suffix}", fields.join(sep));
    }
    t
}

/// `layers` layers as text ([`layer_text`]), `suffix(k)` after each line
/// of layer `k` and `between` after each layer.
fn text(layers: usize, sep: &str, suffix: impl Fn(usize) -> String, between: &str) -> String {
    (0..layers)
        .map(|k| layer_text(k, sep, &suffix(k)) + between)
        .collect()
}

/// A fresh folder in this binary's scratch folder.
fn folder(name: &str) -> PathBuf {
    let d = common::scratch().join(name);
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn read(path: &Path) -> Toolpath {
    load_toolpath(path, &Placement::default()).unwrap()
}

/// Each layer's name and waypoint count.
fn shape(tp: &Toolpath) -> Vec<(String, usize)> {
    tp.layers
        .iter()
        .map(|l| (l.name.clone(), l.waypoints.len()))
        .collect()
}

/// `plan --backend cpu --no-plots` of `input` into `<input>.out`: its
/// report.json, the layer of each row of plan.csv, and stderr.
fn plan(input: &Path, args: &[&str]) -> (serde_json::Value, Vec<usize>, String) {
    let out = input.with_extension("out");
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-o"])
        .arg(&out)
        .arg(input)
        .args(args)
        .output()
        .unwrap();
    common::assert_success(&o);
    let csv = fs::read_to_string(out.join("plan.csv")).unwrap();
    let layers = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    (
        common::read_json(&out.join("report.json")),
        layers,
        common::stderr(&o),
    )
}

/// The plan of a tiny part printed from beads: every waypoint planned,
/// none colliding, in `layers` layers.
fn assert_planned_from_beads(report: &serde_json::Value, rows: &[usize], layers: usize) {
    assert_eq!(report["part"], "beads", "{report}");
    assert_eq!(report["plan"]["waypoints"], 21 * layers as u64);
    assert_eq!(report["plan"]["skipped_waypoints"], 0);
    assert_eq!(report["plan"]["colliding_edges"], 0);
    assert_eq!(report["warnings"].as_array().unwrap().len(), 0, "{report}");
    assert_eq!(rows.len(), 21 * layers);
    assert_eq!(rows.iter().max(), Some(&(layers - 1)));
}

#[test]
fn a_waypoint_folder_without_layer_surfaces() {
    let d = folder("folder");
    let tp = d.join("tp");
    fs::create_dir_all(tp.join("waypoint")).unwrap();
    for k in 0..3 {
        fs::write(tp.join(format!("waypoint/{k}.txt")), layer_text(k, " ", "")).unwrap();
    }
    let back = read(&tp);
    assert_eq!(
        shape(&back),
        vec![("0".into(), 21), ("1".into(), 21), ("2".into(), 21)]
    );
    assert!(back.layers.iter().all(|l| l.surface.is_none()));
    assert_eq!(back.layers[2].waypoints[0].pos, [-5.0, 0.0, 1.0]);
    let (report, rows, _) = plan(&tp, &[]);
    assert_planned_from_beads(&report, &rows, 3);
}

/// `file` read back as the tiny part's layers named `names` (21
/// waypoints each), and planned from its beads; the toolpath read.
fn read_and_plan(file: &Path, names: &[&str]) -> Toolpath {
    let back = read(file);
    let want: Vec<(String, usize)> = names.iter().map(|n| (n.to_string(), 21)).collect();
    assert_eq!(shape(&back), want);
    let (report, rows, _) = plan(file, &[]);
    assert_planned_from_beads(&report, &rows, names.len());
    back
}

#[test]
fn a_single_file_with_layers_separated_by_blank_lines() {
    let file = folder("blank").join("part.txt");
    fs::write(&file, text(3, " ", |_| String::new(), "\n")).unwrap();
    let back = read_and_plan(&file, &["0", "1", "2"]);
    assert_eq!(back.layers[1].waypoints[0].pos, [5.0, 0.0, 0.5]);
}

#[test]
fn a_single_file_with_a_layer_column() {
    let file = folder("column").join("part.txt");
    let names = ["10", "11", "11S"];
    fs::write(&file, text(3, ",", |k| format!(",{}", names[k]), "")).unwrap();
    let back = read_and_plan(&file, &names);
    assert!(back.layers[2].is_support());
}

#[test]
fn a_csv_whose_header_names_the_columns() {
    let file = folder("csv").join("part.csv");
    // The columns in another order, names in upper case, an extra column.
    let mut t = String::from("Layer,NZ,ny,nx,Z,Y,X,feed\n");
    for k in 0..2 {
        for [x, y, z, a, b, c] in line(k) {
            let _ = writeln!(t, "{k},{c},{b},{a},{z},{y},{x},1500");
        }
    }
    fs::write(&file, &t).unwrap();
    let back = read_and_plan(&file, &["0", "1"]);
    assert_eq!(back.layers[1].waypoints[3].pos, line(1)[3][..3]);
    assert_eq!(back.layers[1].waypoints[3].dir, [0.0, 0.0, 1.0]);
}

/// Y-up and `--place` apply to a single file as to a folder.
#[test]
fn a_single_file_is_placed_like_a_folder() {
    let file = folder("placed").join("part.csv");
    fs::write(&file, "x y z nx ny nz\n1 2 3 0 1 0\n").unwrap();
    let place = Placement {
        y_up: true,
        offset: [10.0, 0.0, 0.0],
    };
    let back = load_toolpath(&file, &place).unwrap();
    assert_eq!(back.layers[0].waypoints[0].pos, [11.0, -3.0, 2.0]);
    assert_eq!(back.layers[0].waypoints[0].dir, [0.0, 0.0, 1.0]);
}

/// A single file without layer information is one layer as read; the job
/// finds its layers from how its beads stack.
#[test]
fn a_single_file_without_layers_gets_them_from_its_beads() {
    let file = folder("stacked").join("part.txt");
    fs::write(&file, text(3, " ", |_| String::new(), "")).unwrap();
    assert_eq!(shape(&read(&file)), vec![("part".into(), 63)]);
    let (report, rows, _) = plan(&file, &[]);
    assert_planned_from_beads(&report, &rows, 3);
}

/// With no part model (`--part surfaces` where there are none), `plan`,
/// `check` and `simulate` say on stderr and in their reports that only the
/// platform was checked.
#[test]
fn only_the_platform_checked_is_said() {
    let d = folder("platform_only");
    let file = d.join("part.txt");
    fs::write(&file, text(2, " ", |_| String::new(), "\n")).unwrap();
    let only = "only the platform was checked";
    let (report, _, stderr) = plan(&file, &["--part", "surfaces"]);
    assert_eq!(report["part"], "platform only");
    let warnings = report["warnings"].as_array().unwrap();
    assert!(warnings[0].as_str().unwrap().contains(only), "{report}");
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("warning:") && l.contains(only)),
        "{stderr}"
    );

    let json = d.join("check.json");
    let o = common::maamplan()
        .args(["check", "--backend", "cpu", "--part", "surfaces", "--json"])
        .arg(&json)
        .arg(&file)
        .output()
        .unwrap();
    common::assert_success(&o);
    assert!(common::stderr(&o).contains(only));
    let check = common::read_json(&json);
    assert_eq!(check["part"], "platform only");
    assert!(check["warnings"][0].as_str().unwrap().contains(only));

    // The planned program simulated against its beads, then against no part.
    let gcode = file.with_extension("out").join("toolpath.gcode");
    for (part, expect) in [("beads", "beads"), ("surfaces", "platform only")] {
        let out = d.join(format!("sim-{part}"));
        let o = common::maamplan()
            .args(["simulate", "--backend", "cpu", "--no-plots", "--part", part])
            .arg(&gcode)
            .arg(&file)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        common::assert_success(&o);
        let sim = common::read_json(&out.join("report.json"));
        assert_eq!(sim["part"], expect);
        let warned = sim["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains(only));
        assert_eq!(warned, expect == "platform only", "{sim}");
        assert_eq!(common::stderr(&o).contains(only), warned);
    }
}

/// In a single file without layers, an axis pointing into the material
/// below is reversed, and the summary says so in those words (not the
/// data set's rule for whole layers that mostly point down).
#[test]
fn axes_into_the_material_are_reversed_and_said_to_be() {
    let dir = folder("against");
    let file = dir.join("part.txt");
    let down = |k: usize| layer_text(k, " ", "").replace(" 0 0 1\n", " 0 0 -1\n");
    fs::write(&file, layer_text(0, " ", "") + &down(1) + &down(2)).unwrap();
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-o"])
        .arg(dir.join("out"))
        .arg(&file)
        .output()
        .unwrap();
    common::assert_success(&o);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("reversed the nozzle directions of 2 layer(s) holding nozzle axes that pointed into the material below"),
        "{said}"
    );
    let report = common::read_json(&dir.join("out").join("report.json"));
    assert_eq!(
        report["flipped_layers"].as_array().unwrap().len(),
        2,
        "{report}"
    );
}
