//! Watching the program run: `simulate -o` on the data set's reference
//! G-code writes `program.glb`, an animation the Khronos validator
//! accepts, in which the head stands at each colliding line at the time
//! report.html gives and the part holds exactly the layers printed so
//! far; and report.html pictures each collision with the head and the
//! material it meets, the pair highlighted.

mod common;

use common::{data, read_json, screenshot, validate};
use glam::{DMat3, DVec3, Mat4, Quat, Vec3};
use maamplan::io::gcode_read::{axes_of, load_program};
use maamplan::kinematics::Machine;
use maamplan::report::snapshot::HIGHLIGHT;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The reference program's colliding lines the FCL audit confirms.
const COLLIDING: [usize; 3] = [25844, 35940, 36071];

fn reference() -> PathBuf {
    data().join("reference_gcode/simple_curve_Gcode.txt")
}

/// `simulate REFERENCE -o OUT` (cpu backend), run once.
fn simulated() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| {
        let out = common::scratch().join("program_scene");
        let o = common::cli(&[
            "simulate",
            reference().to_str().unwrap(),
            "--backend",
            "cpu",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ]);
        common::assert_success(&o);
        out
    })
}

/// The page's problem pictures: (kind, line) → (time, PNG bytes).
fn pictures() -> HashMap<(String, usize), (f64, Vec<u8>)> {
    use base64::Engine;
    let html = std::fs::read_to_string(simulated().join("report.html")).unwrap();
    let mut out = HashMap::new();
    for fig in html.split("<figure class=\"problem\" id=\"").skip(1) {
        let id = &fig[..fig.find('"').unwrap()];
        let (kind, line) = id.rsplit_once('-').unwrap();
        let attr = |name: &str| {
            let at = fig.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
            fig[at..at + fig[at..].find('"').unwrap()].to_string()
        };
        let time: f64 = attr("data-time").parse().unwrap();
        let src = attr("src");
        let b64 = src.strip_prefix("data:image/png;base64,").unwrap();
        let png = base64::engine::general_purpose::STANDARD
            .decode(b64)
            .unwrap();
        out.insert((kind.to_string(), line.parse().unwrap()), (time, png));
    }
    out
}

/// One animated property: does it step, its key times and values.
type Channel = (bool, Vec<f32>, Vec<Vec<f32>>);

/// The animation of a glTF file, evaluated by hand.
struct Animated {
    doc: gltf::Document,
    /// Per node and property.
    channels: HashMap<(usize, &'static str), Channel>,
    parent: HashMap<usize, usize>,
}

impl Animated {
    fn load(path: &Path) -> Animated {
        let (doc, buffers, _) = gltf::import(path).unwrap();
        let mut channels = HashMap::new();
        for anim in doc.animations() {
            for ch in anim.channels() {
                let r = ch.reader(|b| Some(&buffers[b.index()]));
                let times: Vec<f32> = r.read_inputs().unwrap().collect();
                use gltf::animation::util::{ReadOutputs, Rotations};
                let (path, values): (&str, Vec<Vec<f32>>) = match r.read_outputs().unwrap() {
                    ReadOutputs::Translations(v) => {
                        ("translation", v.map(|x| x.to_vec()).collect())
                    }
                    ReadOutputs::Scales(v) => ("scale", v.map(|x| x.to_vec()).collect()),
                    ReadOutputs::Rotations(Rotations::F32(v)) => {
                        ("rotation", v.map(|x| x.to_vec()).collect())
                    }
                    _ => panic!("unexpected output"),
                };
                let step = ch.sampler().interpolation() == gltf::animation::Interpolation::Step;
                channels.insert((ch.target().node().index(), path), (step, times, values));
            }
        }
        let mut parent = HashMap::new();
        for n in doc.nodes() {
            for c in n.children() {
                parent.insert(c.index(), n.index());
            }
        }
        Animated {
            doc,
            channels,
            parent,
        }
    }

    fn node(&self, name: &str) -> usize {
        self.doc
            .nodes()
            .find(|n| n.name() == Some(name))
            .unwrap_or_else(|| panic!("no node {name}"))
            .index()
    }

    /// The animation's last key.
    fn duration(&self) -> f32 {
        self.channels
            .values()
            .map(|c| *c.1.last().unwrap())
            .fold(0.0, f32::max)
    }

    /// `node`'s `path` at time `t`, if animated.
    fn value(&self, node: usize, path: &'static str, t: f32) -> Option<Vec<f32>> {
        let (step, times, values) = self.channels.get(&(node, path))?;
        let k = times.partition_point(|&x| x <= t);
        if k == 0 {
            return Some(values[0].clone());
        }
        if k == times.len() || *step {
            return Some(values[k - 1].clone());
        }
        let f = (t - times[k - 1]) / (times[k] - times[k - 1]);
        let (a, b) = (&values[k - 1], &values[k]);
        Some(if path == "rotation" {
            let qa = Quat::from_slice(a);
            let qb = Quat::from_slice(b);
            qa.slerp(qb, f).to_array().to_vec()
        } else {
            a.iter().zip(b).map(|(x, y)| x + f * (y - x)).collect()
        })
    }

    /// `node`'s transform in the scene at time `t`.
    fn world(&self, node: usize, t: f32) -> Mat4 {
        let n = self.doc.nodes().nth(node).unwrap();
        let (t0, r0, s0) = n.transform().decomposed();
        let tr = self
            .value(node, "translation", t)
            .map_or(Vec3::from(t0), |v| Vec3::from_slice(&v));
        let rot = self
            .value(node, "rotation", t)
            .map_or(Quat::from_array(r0), |v| Quat::from_slice(&v));
        let sc = self
            .value(node, "scale", t)
            .map_or(Vec3::from(s0), |v| Vec3::from_slice(&v));
        let local = Mat4::from_scale_rotation_translation(sc, rot, tr);
        match self.parent.get(&node) {
            Some(&p) => self.world(p, t) * local,
            None => local,
        }
    }
}

#[test]
fn the_program_scene_validates_and_runs_the_whole_program() {
    let glb = simulated().join("program.glb");
    if let Some(r) = validate(&glb) {
        assert_eq!(r["errors"], 0, "{r}");
    }
    let a = Animated::load(&glb);
    let seconds = read_json(&simulated().join("report.json"))["summary"]["seconds"]
        .as_f64()
        .unwrap();
    assert!(seconds > 1000.0);
    assert!(
        (a.duration() as f64 - seconds).abs() < 1e-4 * seconds,
        "animation {} s, program {seconds} s",
        a.duration()
    );
}

#[test]
fn the_head_stands_at_each_colliding_line_at_the_time_the_page_gives() {
    let a = Animated::load(&simulated().join("program.glb"));
    let m = Machine::default();
    let program = load_program(&reference(), &m).unwrap();
    let pictures = pictures();
    let (head, table) = (a.node("head"), a.node("table"));
    for line in COLLIDING {
        let (time, _) = pictures[&("collision".to_string(), line)];
        let rel = a.world(table, time as f32).inverse() * a.world(head, time as f32);
        let mv = program.moves.iter().find(|mv| mv.line == line).unwrap();
        let pose = m.pose(&axes_of(&mv.to));
        let tip = rel.transform_point3(Vec3::ZERO).as_dvec3();
        let off = (tip - DVec3::from(pose.tip.map(|x| x as f64))).length();
        assert!(off < 0.05, "line {line}: the head's tip is {off} mm off");
        let r = DMat3::from_mat4(rel.as_dmat4());
        for (k, col) in pose.cols.iter().enumerate() {
            let d = (r.col(k) - Vec3::from(*col).as_dvec3()).length();
            assert!(d < 2e-3, "line {line}: the head's axis {k} is {d} off");
        }
    }
}

#[test]
fn at_a_colliding_line_the_part_holds_exactly_the_layers_printed_so_far() {
    let a = Animated::load(&simulated().join("program.glb"));
    let report = read_json(&simulated().join("report.json"));
    // The layers the program lays are named by their index.
    let layer_of = |line: usize| {
        report["problems"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["line"] == line)
            .and_then(|p| p["layer"].as_str()?.parse::<usize>().ok())
            .unwrap()
    };
    let chunks: Vec<(usize, usize)> = a
        .doc
        .nodes()
        .filter_map(|n| {
            let name = n.name()?.strip_prefix("layer ")?;
            let layer = name.split(' ').next()?.parse().ok()?;
            Some((n.index(), layer))
        })
        .collect();
    let layers = chunks.iter().map(|c| c.1).max().unwrap() + 1;
    assert!(
        layers >= 20 && chunks.len() > layers,
        "{layers} layers, {} chunks",
        chunks.len()
    );
    let pictures = pictures();
    for line in COLLIDING {
        let (time, _) = pictures[&("collision".to_string(), line)];
        let current = layer_of(line);
        assert!(current > 0 && current + 1 < layers);
        let mut seen = vec![(0, 0); layers];
        for &(node, layer) in &chunks {
            let s = a.value(node, "scale", time as f32).unwrap();
            seen[layer].0 += (s[0] > 0.5) as usize;
            seen[layer].1 += 1;
        }
        for (l, &(shown, all)) in seen.iter().enumerate() {
            match l.cmp(&current) {
                std::cmp::Ordering::Less => {
                    assert_eq!(shown, all, "line {line}: layer {l} printed")
                }
                std::cmp::Ordering::Greater => {
                    assert_eq!(shown, 0, "line {line}: layer {l} not yet")
                }
                std::cmp::Ordering::Equal => {
                    assert!(shown < all, "line {line}: its layer is being printed")
                }
            }
        }
    }
}

/// Pixels of `png` in the highlight colour, and their mean position as a
/// share of the picture's size.
fn highlighted(png: &[u8]) -> (usize, [f64; 2]) {
    let img = image::load_from_memory(png).unwrap().to_rgba8();
    let mut n = 0;
    let mut sum = [0.0; 2];
    for (x, y, p) in img.enumerate_pixels() {
        if p.0[..3] == HIGHLIGHT[..3] {
            n += 1;
            sum[0] += x as f64 / img.width() as f64;
            sum[1] += y as f64 / img.height() as f64;
        }
    }
    (n, sum.map(|s| s / n.max(1) as f64))
}

#[test]
fn each_collision_is_pictured_with_the_head_and_what_it_meets() {
    let pictures = pictures();
    let mut seen: Vec<&Vec<u8>> = Vec::new();
    for line in COLLIDING {
        let (_, png) = &pictures[&("collision".to_string(), line)];
        let (n, at) = highlighted(png);
        assert!(n >= 20, "line {line}: {n} highlighted pixels");
        // The camera looks at what the head meets.
        assert!(
            at.iter().all(|&c| (0.25..0.75).contains(&c)),
            "line {line}: the highlight is off centre at {at:?}"
        );
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        let count = |f: &dyn Fn([u8; 3]) -> bool| img.pixels().filter(|p| f(p.0)).count();
        // The head: dark grey, or cyan where it is within the margin.
        let head = count(&|[r, g, b]| {
            (r < 110 && g < 110 && b < 130 && b >= r) || (r < 60 && b > 120 && g > 100)
        });
        // The part: beige.
        let part = count(&|[r, g, b]| r > 110 && r > b + 15 && g > b);
        assert!(
            head > 2000 && part > 2000,
            "line {line}: head {head} px, part {part} px"
        );
        assert!(
            !seen.contains(&png),
            "line {line}: the same picture as another line"
        );
        seen.push(png);
    }
    // Without a highlight the check above fails: the kinds that meet
    // nothing have none.
    let (_, blob) = pictures.iter().find(|(k, _)| k.0 == "blob").unwrap();
    assert_eq!(highlighted(&blob.1).0, 0);
}

#[test]
fn the_simulation_page_renders_with_its_pictures_in_chromium() {
    // Tall enough for the overview and the four collisions' pictures.
    let Some(img) = screenshot(&simulated().join("report.html"), 1000, 4800) else {
        return;
    };
    let magenta = |y: u32| {
        (0..img.width())
            .any(|x| img.get_pixel(x, y).0 == [HIGHLIGHT[0], HIGHLIGHT[1], HIGHLIGHT[2]])
    };
    // Runs of rows holding the highlight, more than a picture's margin apart.
    let mut pictures = 0;
    let mut last = None;
    for y in (0..img.height()).filter(|&y| magenta(y)) {
        if last.is_none_or(|l| y > l + 60) {
            pictures += 1;
        }
        last = Some(y);
    }
    assert!(
        pictures >= 4,
        "{pictures} pictured collisions rendered on the page"
    );
}

/// The data set's README, "The whole machine": for axes X Y Z B C a point
/// `p` of the cradle goes to `Ry(B) p − (X, Y, 0)`, of the table and part
/// to `Ry(B) Rz(C) p − (X, Y, 0)`, of the head's carriage to
/// `p + (0, 0, Z)`; of the Y carriage to `p − (X, Y, 0)`.
#[test]
fn the_machines_bodies_move_as_the_data_set_says() {
    let a = Animated::load(&simulated().join("program.glb"));
    let root = a.node("machine (mm, Z up)");
    let program = load_program(&reference(), &Machine::default()).unwrap();
    let pictures = pictures();
    let (time, _) = pictures[&("collision".to_string(), COLLIDING[0])];
    let mv = program
        .moves
        .iter()
        .find(|mv| mv.line == COLLIDING[0])
        .unwrap();
    let [x, y, z, b, c] = mv.to.map(|v| v as f32);
    assert!(b.abs() > 5.0, "a tilted line");
    let (b, c) = (b.to_radians(), c.to_radians());
    let p = Vec3::new(12.0, -7.0, 30.0);
    let moved = |node: &str| {
        let m = a.world(root, time as f32).inverse() * a.world(a.node(node), time as f32);
        m.transform_point3(p)
    };
    let ry = Mat4::from_rotation_y(b);
    let rz = Mat4::from_rotation_z(c);
    let shift = Vec3::new(x, y, 0.0);
    let expect = [
        ("machine body 3 (Cradle)", ry.transform_point3(p) - shift),
        ("table", (ry * rz).transform_point3(p) - shift),
        ("machine body 4 (Head)", p + Vec3::new(0.0, 0.0, z)),
        ("machine body 2 (Xy)", p - shift),
        ("machine body 1 (X)", p - Vec3::new(x, 0.0, 0.0)),
        ("machine body 0 (Base)", p),
    ];
    for (node, want) in expect {
        let got = moved(node);
        assert!((got - want).length() < 0.01, "{node}: {got} against {want}");
    }
}

/// Without a GPU adapter the page says why it has no pictures, and the
/// scene is written all the same.
#[test]
fn without_an_adapter_the_page_says_so_and_the_scene_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = common::maamplan()
        // No Metal adapter on Linux, nor any other when only Metal is asked.
        .env("WGPU_BACKEND", "metal")
        .args([
            "plan",
            "--backend",
            "cpu",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    common::assert_success(&o);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("id=\"no-pictures\""), "the page has pictures");
    assert!(!html.contains("data:image/png"));
    assert!(out.join("program.glb").is_file());
}
