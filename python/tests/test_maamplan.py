"""The Python calls against the command line on the same inputs: the same
verdicts as ``check``, the same plan.csv as ``plan``, the same colliding
lines as ``simulate``; scenes built with trimesh; errors; the GPU path."""

import os

import numpy as np
import pytest
import trimesh

import maamplan
from conftest import DATA, SIMPLE, SIMPLE_ARGS, cli, cli_json

REFERENCE_GCODE = DATA / "reference_gcode" / "simple_curve_Gcode.txt"


def test_collides_gives_checks_verdicts(simple_scene, tmp_path):
    out = tmp_path / "check.json"
    cli("check", DATA / "simple_curve", *SIMPLE_ARGS, "--backend", "cpu", "--json", out, "-q")
    expected = cli_json(out)["colliding_waypoints"]
    poses = simple_scene.poses()
    assert poses.shape == (41494, 4, 4)
    hits = maamplan.Evaluator(simple_scene, backend="cpu").collides(poses, simple_scene.cutoffs)
    assert hits.dtype == np.bool_ and hits.shape == (41494,)
    assert list(np.flatnonzero(hits)) == expected
    assert len(expected) == 5


def test_collides_takes_tips_and_directions(simple_scene):
    ev = maamplan.Evaluator(simple_scene, backend="cpu")
    tips, dirs = simple_scene.positions, simple_scene.directions
    # Every pose against the whole part: the layers above a waypoint are
    # in the way of its head.
    whole = ev.collides((tips[::500], dirs[::500]))
    before = ev.collides((tips[::500], dirs[::500]), simple_scene.cutoffs[::500])
    assert whole.sum() > before.sum()
    # A nozzle pointing straight into the platform collides at any margin.
    down = ev.collides((np.array([[0.0, 0.0, 41.0]]), np.array([[0.0, 0.0, -1.0]])), margin=0.0)
    assert down.tolist() == [True]


def test_plan_gives_plan_csv(tmp_path):
    out = tmp_path / "cli"
    cli("plan", DATA / "simple_curve", *SIMPLE_ARGS, "--backend", "cpu", "--no-plots", "-o", out, "-q")
    expected = (out / "plan.csv").read_text()
    calls = []
    plan = maamplan.plan(
        str(DATA / "simple_curve"), backend="cpu", progress=lambda *e: calls.append(e), **SIMPLE
    )
    assert plan.csv() == expected
    rows = np.genfromtxt(out / "plan.csv", delimiter=",", names=True)
    cli_axes = np.column_stack([rows[c] for c in ("X", "Y", "Z", "B", "C")])
    assert np.allclose(plan.axes, cli_axes, atol=5e-4, equal_nan=True)
    assert (plan.was_colliding == rows["was_colliding"].astype(bool)).all()
    assert plan.report["plan"]["residual_collisions"] == 0
    stages = {stage for stage, _, _ in calls}
    assert {"loading", "columns", "verify"} <= stages
    assert any(total > 0 and done == total for _, done, total in calls)
    written = plan.write(tmp_path / "py", plots=False)
    assert (written / "plan.csv").read_text() == expected
    body = lambda p: [l for l in p.read_text().splitlines() if not l.startswith(";")]
    assert body(written / "toolpath.gcode") == body(out / "toolpath.gcode")
    # With plots, the command line's report files too, the program scene among them.
    report = plan.write(tmp_path / "report")
    for name in ("scene.glb", "program.glb", "report.html", "plots"):
        assert (report / name).exists(), name
    assert (report / "program.glb").read_bytes()[:4] == b"glTF"


def test_simulate_finds_the_reference_gcodes_collisions(tmp_path):
    out = tmp_path / "sim"
    cli("simulate", REFERENCE_GCODE, "--head", SIMPLE["head"], "--platform", SIMPLE["platform"],
        "--backend", "cpu", "--no-plots", "-o", out, "-q")
    expected = sorted(p["line"] for p in cli_json(out / "report.json")["problems"]
                      if p["kind"] == "collision")
    sim = maamplan.simulate(str(REFERENCE_GCODE), head=SIMPLE["head"],
                            platform=SIMPLE["platform"], backend="cpu")
    lines = sim.colliding_lines.tolist()
    assert lines == expected
    times = {p["line"]: p["time_s"] for p in cli_json(out / "report.json")["problems"]}
    assert all(abs(p["time_s"] - times[p["line"]]) < 1e-9 for p in sim.problems)
    assert {25844, 35940, 36071} <= set(lines)
    assert len(sim.line) == sim.summary["moves"]
    assert [p["line"] for p in sim.problems if p["kind"] == "collision"] == lines
    assert sim.report["summary"]["colliding_moves"] == len(lines)


def cone_head():
    """A 45° cone, radius 20 mm: tip at the origin, the head up +z."""
    cone = trimesh.creation.cone(radius=20.0, height=20.0, sections=48)
    flip = trimesh.transformations.rotation_matrix(np.pi, [1, 0, 0])
    cone.apply_transform(flip)
    cone.apply_translation([0, 0, 20.0])
    return cone


def test_a_trimesh_scene_matches_check_on_its_files(tmp_path):
    head = cone_head()
    assert head.is_watertight and abs(head.bounds[0][2]) < 1e-9
    plate = trimesh.creation.box(extents=(200, 200, 2))
    plate.apply_translation([0, 0, -1])
    # Two rows of waypoints 0.5 mm above the plate, the second tilting
    # ever further: the cone's rim meets the plate past 45°.
    x = np.linspace(-20, 20, 41)
    tilt = np.radians(np.linspace(0, 80, 41))
    pos = np.column_stack([np.r_[x, x], np.full(82, 5.0), np.full(82, 0.5)])
    pos[41:, 1] = -5.0
    dirs = np.column_stack([np.r_[np.zeros(41), np.sin(tilt)], np.zeros(82),
                            np.r_[np.ones(41), np.cos(tilt)]])
    layer = np.r_[np.zeros(41), np.ones(41)].astype(int)
    tp = maamplan.Toolpath.from_arrays(pos, dirs, layer)
    scene = maamplan.Scene(tp, head=head, platform=(plate.vertices, plate.faces))
    hits = maamplan.Evaluator(scene, backend="cpu").collides(scene.poses(), scene.cutoffs)
    assert 0 < hits.sum() < 82
    # The same inputs as files, through the command line.
    head.export(tmp_path / "head.stl")
    plate.export(tmp_path / "plate.obj")
    csv = tmp_path / "toolpath.csv"
    rows = [f"{l},{p[0]},{p[1]},{p[2]},{d[0]},{d[1]},{d[2]}" for l, p, d in zip(layer, pos, dirs)]
    csv.write_text("layer,x,y,z,nx,ny,nz\n" + "\n".join(rows) + "\n")
    out = tmp_path / "check.json"
    cli("check", csv, "--head", tmp_path / "head.stl", "--platform", tmp_path / "plate.obj",
        "--backend", "cpu", "--json", out, "-q")
    assert list(np.flatnonzero(hits)) == cli_json(out)["colliding_waypoints"]


def test_errors_carry_the_command_lines_message(tmp_path):
    missing = tmp_path / "nowhere"
    done = cli("check", missing, check=False)
    assert done.returncode == 2
    with pytest.raises(maamplan.InputError) as raised:
        maamplan.Scene(str(missing))
    assert isinstance(raised.value, maamplan.MaamplanError)
    assert not isinstance(raised.value, maamplan.InternalError)
    assert f"error: {raised.value}" == done.stderr.strip()
    with pytest.raises(maamplan.InputError, match="backend must be"):
        maamplan.plan(str(missing), backend="fast")
    bad = tmp_path / "bad.gcode"
    bad.write_text("G28 X0 Y0 Z0 B0 C0\nG2 X1 Y1\n")
    done = cli("simulate", bad, check=False)
    with pytest.raises(maamplan.InputError) as raised:
        maamplan.simulate(str(bad))
    assert done.returncode == 2 and f"error: {raised.value}" == done.stderr.strip()


def test_progress_hears_batches_and_its_exceptions_are_raised(simple_scene):
    ev = maamplan.Evaluator(simple_scene, backend="cpu")
    poses = simple_scene.poses()[:40000]
    heard = []
    ev.collides(poses, progress=lambda stage, done, total: heard.append((stage, done, total)))
    assert heard[0] == ("collides", 0, 0) and heard[-1] == ("collides", 40000, 40000)

    def stop(stage, done, total):
        raise KeyboardInterrupt("stop")

    with pytest.raises(KeyboardInterrupt):
        ev.collides(poses, progress=stop)


def test_gpu_backend_gives_the_cpus_verdicts(simple_scene):
    try:
        gpu = maamplan.Evaluator(simple_scene, backend="gpu")
    except maamplan.InputError as e:
        if os.environ.get("MAAMPLAN_REQUIRE_GPU") == "1":
            raise
        pytest.skip(f"no GPU adapter: {e}")
    poses, cutoffs = simple_scene.sample_poses(8000, tilts=3)
    cpu = maamplan.Evaluator(simple_scene, backend="cpu")
    expected = cpu.collides(poses, cutoffs, margin=0.0)
    assert 0 < expected.sum() < len(expected)
    assert (gpu.collides(poses, cutoffs, margin=0.0) == expected).all()
    assert gpu.backend == "gpu"


def test_arrays_with_surfaces_are_the_part_in_print_order():
    plate = trimesh.creation.box(extents=(200, 200, 2))
    plate.apply_translation([0, 0, -1])
    # Two flat layers, 0.5 and 1.0 mm up, each a square surface; the
    # waypoints run along x.
    square = lambda z: (np.array([[-30, -30, z], [30, -30, z], [30, 30, z], [-30, 30, z]]),
                        np.array([[0, 1, 2], [0, 2, 3]]))
    x = np.linspace(-10, 10, 21)
    pos = np.column_stack([np.r_[x, x], np.zeros(42), np.r_[np.full(21, 0.5), np.full(21, 1.0)]])
    dirs = np.tile([0.0, 0.0, 1.0], (42, 1))
    layer = np.r_[np.zeros(21), np.ones(21)]
    tp = maamplan.Toolpath.from_arrays(pos, dirs, layer, surfaces=[square(0.5), square(1.0)])
    scene = maamplan.Scene(tp, head=cone_head(), platform=plate)
    assert scene.part == "surfaces" and scene.layer_names == ["0", "1"]
    ev = maamplan.Evaluator(scene, backend="cpu")
    # The tip between the layers (0.4 mm under the second: past the 0.3 mm
    # clearance along the nozzle): clear of the first layer below it while
    # the second is not printed, through the second's surface once it is.
    between = (np.array([[0.0, 0.0, 0.6]] * 2), np.array([[0.0, 0.0, 1.0]] * 2))
    before, after = scene.cutoffs[21], np.iinfo(np.uint32).max
    assert ev.collides(between, np.array([before, after]), margin=0.0).tolist() == [False, True]
