//! What the engineer sees: plots that follow the plan, a glTF scene the
//! Khronos validator accepts, an HTML report that renders in a browser,
//! and clean failures. External tools (node + gltf-validator, chromium)
//! are required where MAAMPLAN_REQUIRE_TOOLS=1 (CI); elsewhere the tests
//! that need them say why they skip.

mod common;

use common::{default_plan, screenshot, simple_curve_plan, validate};
use maamplan::kinematics::Machine;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{Plan, PlanOptions};
use maamplan::report::plots::{figures, Figure};
use maamplan::report::scene_glb::scene_glb;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The figures of the default job's plan, drawn once.
fn default_figures() -> &'static [Figure] {
    static FIGURES: OnceLock<Vec<Figure>> = OnceLock::new();
    FIGURES.get_or_init(|| figures(&Machine::default(), &default_plan().2).unwrap())
}

/// The default job planned without smoothing: a different plan of the
/// same toolpath.
fn unsmoothed_default_plan() -> Plan {
    let (job, scene, _) = default_plan();
    let opts = PlanOptions {
        smoothing: Smoothing::None,
        ..PlanOptions::default()
    };
    common::plan_cpu(scene, &job.toolpath, &Machine::default(), &opts)
}

#[test]
fn plots_name_the_speed_the_collisions_and_each_layer() {
    let fa = default_figures();
    let names: Vec<&str> = fa.iter().map(|f| f.name.as_str()).collect();
    assert!(
        names.contains(&"tip_speed")
            && names.contains(&"collisions")
            && names.contains(&"bc_layer_0")
    );
    assert_eq!(fa.len(), 4 + 2, "one B/C plot per layer plus two");
}

/// Deterministic: the same plan draws the same pictures.
#[test]
fn plots_of_the_same_plan_are_the_same() {
    let again = figures(&Machine::default(), &default_plan().2).unwrap();
    assert!(default_figures()
        .iter()
        .zip(&again)
        .all(|(x, y)| x.svg == y.svg));
}

/// A different plan draws a different B/C curve and speed histogram.
#[test]
fn plots_follow_the_plan() {
    let fa = default_figures();
    let fb = figures(&Machine::default(), &unsmoothed_default_plan()).unwrap();
    let differs = |name: &str| {
        let x = fa.iter().find(|f| f.name == name).unwrap();
        let y = fb.iter().find(|f| f.name == name).unwrap();
        x.svg != y.svg
    };
    assert!(differs("bc_layer_1") && differs("tip_speed"));
}

#[test]
fn no_plot_is_nearly_empty() {
    for f in default_figures() {
        assert!(
            f.svg.contains("<svg") && f.svg.len() > 2000,
            "{} is nearly empty",
            f.name
        );
    }
}

/// simple_curve: one B/C plot per layer, plus two.
#[test]
fn simple_curve_draws_a_plot_per_layer() {
    let (_, sc) = simple_curve_plan();
    let fs = figures(&Machine::default(), sc).unwrap();
    assert_eq!(fs.len(), 20 + 2);
}

/// Write `name`'s scene file and run the Khronos validator on it: no
/// errors.
fn assert_scene_validates(name: &str, scene: &maamplan::scene::Scene, p: &Plan) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{name}.glb"));
    std::fs::write(&path, scene_glb(scene, p, &Machine::default())).unwrap();
    if let Some(r) = validate(&path) {
        assert_eq!(r["errors"], 0, "{name}: {r}");
    }
}

#[test]
fn default_scene_passes_the_khronos_gltf_validator() {
    let (_, scene, p) = default_plan();
    assert_scene_validates("default", scene, p);
}

#[test]
fn simple_curve_scene_passes_the_khronos_gltf_validator() {
    let (job, p) = simple_curve_plan();
    assert_scene_validates("simple_curve", &job.scene, p);
}

/// The output folder of `maamplan plan --backend cpu -q` (the embedded
/// default job, with its report), run once.
fn planned_report() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| common::plan_default_job("report", &["-q"]))
}

#[test]
fn plan_writes_the_report_the_scene_and_the_plots() {
    let out = planned_report();
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
}

#[test]
fn the_report_is_self_contained() {
    let html = std::fs::read_to_string(planned_report().join("report.html")).unwrap();
    for load in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(!html.contains(load), "self-contained: it loads {load}…");
    }
    assert!(html.contains("<svg") && html.contains("id=\"summary\""));
}

#[test]
fn report_renders_in_headless_chromium() {
    let out = planned_report();
    let Some(img) = screenshot(&out.join("report.html"), 1000, 2400) else {
        return;
    };
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

/// Run `plan` with `args` in a fresh folder (`{dir}` in an argument
/// stands for the folder, `{out}` for the output folder `{dir}/out`),
/// after `prepare` wrote its inputs there: it must fail with exit 2 and
/// leave nothing behind, neither the output folder nor a scratch folder.
/// Returns what it said on stderr.
fn plan_fails_cleanly(args: &[&str], prepare: impl FnOnce(&Path)) -> String {
    let dir = tempfile::tempdir().unwrap();
    prepare(dir.path());
    let out = dir.path().join("out");
    let args: Vec<String> = args
        .iter()
        .map(|a| {
            a.replace("{out}", out.to_str().unwrap())
                .replace("{dir}", dir.path().to_str().unwrap())
        })
        .collect();
    let o = common::maamplan().arg("plan").args(&args).output().unwrap();
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(!out.exists(), "{args:?} wrote {}", out.display());
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        left.iter()
            .all(|n| !n.to_string_lossy().starts_with(".maamplan-")),
        "{left:?}"
    );
    err
}

/// Input error: a malformed waypoint file, named with its line, in one line.
#[test]
fn a_malformed_toolpath_fails_cleanly() {
    let err = plan_fails_cleanly(
        &["{dir}/bad.txt", "--backend", "cpu", "-o", "{out}"],
        |dir| std::fs::write(dir.join("bad.txt"), "1 2 3 0 0\n").unwrap(),
    );
    assert!(
        err.contains("bad.txt:1:") && err.lines().count() == 1,
        "{err}"
    );
}

#[test]
fn a_bad_machine_file_fails_cleanly() {
    let err = plan_fails_cleanly(
        &[
            "--backend",
            "cpu",
            "--machine",
            "{dir}/m.toml",
            "-o",
            "{out}",
        ],
        |dir| std::fs::write(dir.join("m.toml"), "configuration = 3\n").unwrap(),
    );
    assert!(err.contains("m.toml:1:"), "{err}");
}

/// Usage errors: no output folder; a bad option value.
#[test]
fn usage_errors_fail_cleanly() {
    let err = plan_fails_cleanly(&["--backend", "cpu"], |_| {});
    assert!(err.contains("--out"), "{err}");
    plan_fails_cleanly(
        &["--backend", "cpu", "--alpha", "90", "-o", "{out}"],
        |_| {},
    );
}

/// Unwritable output: a file where the folder should be.
#[test]
fn an_unwritable_output_fails_cleanly() {
    plan_fails_cleanly(
        &["--backend", "cpu", "-q", "-o", "{dir}/blocker/out"],
        |dir| std::fs::write(dir.join("blocker"), "x").unwrap(),
    );
}
