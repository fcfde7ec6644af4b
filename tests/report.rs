//! What the engineer sees: plots that follow the plan, a glTF scene the
//! Khronos validator accepts, an HTML report that renders in a browser,
//! and clean failures. External tools (node + gltf-validator, chromium)
//! are required where MAAMPLAN_REQUIRE_TOOLS=1 (CI); elsewhere the tests
//! that need them say why they skip.

mod common;

use maamplan::collide::cpu::CpuBackend;
use maamplan::kinematics::Machine;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{plan, Plan, PlanOptions};
use maamplan::report::plots::figures;
use maamplan::report::scene_glb::scene_glb;
use maamplan::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::Command;

fn require_tools() -> bool {
    std::env::var("MAAMPLAN_REQUIRE_TOOLS").is_ok_and(|v| v == "1")
}

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn default_plan(opts: &PlanOptions) -> (Scene, Plan) {
    let (job, scene) = common::default_scene();
    let cpu = CpuBackend::new(&scene);
    let p = plan(
        &scene,
        &job.toolpath,
        &Machine::default(),
        &cpu,
        opts,
        &mut |_| {},
    )
    .unwrap();
    (scene, p)
}

fn simple_curve_plan() -> &'static (Scene, Plan) {
    static PLAN: std::sync::OnceLock<(Scene, Plan)> = std::sync::OnceLock::new();
    PLAN.get_or_init(simple_curve_plan_uncached)
}

fn simple_curve_plan_uncached() -> (Scene, Plan) {
    let (tp, scene) = common::simple_curve();
    let cpu = CpuBackend::new(&scene);
    let p = plan(
        &scene,
        &tp,
        &Machine::default(),
        &cpu,
        &PlanOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    (scene, p)
}

#[test]
fn plots_exist_and_follow_the_plan() {
    let m = Machine::default();
    let (_, a) = default_plan(&PlanOptions::default());
    let (_, b) = default_plan(&PlanOptions {
        smoothing: Smoothing::None,
        ..PlanOptions::default()
    });
    let fa = figures(&m, &a).unwrap();
    let fb = figures(&m, &b).unwrap();
    let names: Vec<&str> = fa.iter().map(|f| f.name.as_str()).collect();
    assert!(
        names.contains(&"tip_speed")
            && names.contains(&"collisions")
            && names.contains(&"bc_layer_0")
    );
    assert_eq!(fa.len(), 4 + 2, "one B/C plot per layer plus two");
    // Deterministic: the same plan draws the same pictures.
    let again = figures(&m, &a).unwrap();
    assert!(fa.iter().zip(&again).all(|(x, y)| x.svg == y.svg));
    // A different plan draws a different B/C curve and speed histogram.
    let differs = |name: &str| {
        let x = fa.iter().find(|f| f.name == name).unwrap();
        let y = fb.iter().find(|f| f.name == name).unwrap();
        x.svg != y.svg
    };
    assert!(differs("bc_layer_1") && differs("tip_speed"));
    for f in &fa {
        assert!(
            f.svg.contains("<svg") && f.svg.len() > 2000,
            "{} is nearly empty",
            f.name
        );
    }
    // simple_curve: one B/C plot per layer, all non-trivial.
    let (_, sc) = simple_curve_plan();
    let fs = figures(&m, sc).unwrap();
    assert_eq!(fs.len(), 20 + 2);
}

/// Run the Khronos validator on `glb`; `None` when it is not installed.
fn validate(glb: &Path) -> Option<serde_json::Value> {
    let script = manifest().join("tools/gltf_validate.cjs");
    let installed = manifest()
        .join("tools/node_modules/gltf-validator")
        .is_dir();
    let node = Command::new("node").arg("--version").output().is_ok();
    if !(installed && node) {
        assert!(!require_tools(), "MAAMPLAN_REQUIRE_TOOLS=1 but node or gltf-validator is missing (npm install --prefix tools)");
        eprintln!("skipping: node or gltf-validator missing (run `npm install --prefix tools`)");
        return None;
    }
    let out = Command::new("node").arg(script).arg(glb).output().unwrap();
    Some(
        serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|_| panic!("validator said: {}", String::from_utf8_lossy(&out.stdout))),
    )
}

#[test]
fn scenes_pass_the_khronos_gltf_validator() {
    let dir = tempfile::tempdir().unwrap();
    let default = default_plan(&PlanOptions::default());
    for (name, (scene, p)) in [("default", &default), ("simple_curve", simple_curve_plan())] {
        let path = dir.path().join(format!("{name}.glb"));
        std::fs::write(&path, scene_glb(scene, p, &Machine::default())).unwrap();
        if let Some(r) = validate(&path) {
            assert_eq!(r["errors"], 0, "{name}: {r}");
        }
    }
}

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

#[test]
fn report_renders_in_headless_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_maamplan"))
        .args(["plan", "--backend", "cpu", "-q", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "report.html",
        "scene.glb",
        "plots/tip_speed.png",
        "plots/tip_speed.svg",
        "plots/collisions.png",
        "plots/bc_layer_0.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for load in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(!html.contains(load), "self-contained: it loads {load}…");
    }
    assert!(html.contains("<svg") && html.contains("id=\"summary\""));
    let Some(browser) = chromium() else {
        assert!(
            !require_tools(),
            "MAAMPLAN_REQUIRE_TOOLS=1 but chromium is missing"
        );
        eprintln!("skipping the screenshot: no chromium");
        return;
    };
    let shot = dir.path().join("shot.png");
    let s = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1000,2400",
        ])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", out.join("report.html").display()))
        .output()
        .unwrap();
    assert!(
        shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&s.stderr)
    );
    let img = image::open(&shot).unwrap().to_rgb8();
    let total = (img.width() * img.height()) as f64;
    let ink = img
        .pixels()
        .filter(|p| p.0.iter().any(|&c| c < 200))
        .count() as f64;
    // The plots' blue (31, 119, 180) is there: the SVGs rendered.
    let blue = img
        .pixels()
        .filter(|p| p.0[2] > 150 && p.0[0] < 80 && p.0[1] > 90 && p.0[1] < 150)
        .count();
    assert!(
        ink / total > 0.02,
        "the page looks blank ({:.3} % ink)",
        100.0 * ink / total
    );
    assert!(blue > 500, "no plot colour on the page ({blue} px)");
}

#[test]
fn failures_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_maamplan"))
            .args(args)
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    // Input error: a malformed waypoint file.
    let tp = dir.path().join("bad.txt");
    std::fs::write(&tp, "1 2 3 0 0\n").unwrap();
    let (code, err) = run(&["plan", tp.to_str().unwrap(), "--backend", "cpu", "-o", o]);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("bad.txt:1:") && err.lines().count() == 1,
        "{err}"
    );
    // Machine-file error.
    let m = dir.path().join("m.toml");
    std::fs::write(&m, "configuration = 3\n").unwrap();
    let (code, err) = run(&[
        "plan",
        "--backend",
        "cpu",
        "--machine",
        m.to_str().unwrap(),
        "-o",
        o,
    ]);
    assert_eq!(code, Some(2));
    assert!(err.contains("m.toml:1:"), "{err}");
    // Usage errors: no output folder; a bad option value.
    let (code, err) = run(&["plan", "--backend", "cpu"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--out"), "{err}");
    let (code, _) = run(&["plan", "--backend", "cpu", "--alpha", "90", "-o", o]);
    assert_eq!(code, Some(2));
    // Unwritable output: a file where the folder should be.
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, "x").unwrap();
    let (code, err) = run(&[
        "plan",
        "--backend",
        "cpu",
        "-q",
        "-o",
        blocker.join("out").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    // Nothing was left: no output folder, no scratch folder.
    assert!(!out.exists());
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        left.iter()
            .all(|n| !n.to_string_lossy().starts_with(".maamplan-")),
        "{left:?}"
    );
}
