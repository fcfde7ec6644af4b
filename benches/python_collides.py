"""Evaluator.collides from Python against `maamplan bench` on the same
poses: bench's own sample of simple_curve (waypoints evenly strided, each
with 3 tilted variants, margin 0), the same backend, timed the same way
(the median of up to 5 runs, at least 2 s of them), in one run: three
rounds, each the command then Python, so that both see the same load.

    python benches/python_collides.py [QUERIES [BACKEND [ROUNDS]]]   # 100000 cpu 3

Needs `pip install ./python` and the release binary (cargo build --release).
"""

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import maamplan

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(os.environ.get("MAAMPLAN_BIN", ROOT / "target" / "release" / "maamplan"))
DATA = Path(os.environ.get("MAAMPLAN_DATASET", ROOT.parent / "shared" / "datasets" / "zhang2021"))
INPUTS = dict(
    head=str(DATA / "extruderHead.obj"),
    platform=str(DATA / "printingPlatform.obj"),
    place=(0.0, 0.0, 40.5),
)


def cli_bench(queries, backend):
    """`maamplan bench`'s result for `backend` on `queries` poses."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.json"
        subprocess.run(
            [str(BIN), "bench", str(DATA / "simple_curve"), "--head", INPUTS["head"],
             "--platform", INPUTS["platform"], "--place", "0,0,40.5", "--backends", backend,
             "--queries", str(queries), "--json", str(out)],
            check=True, capture_output=True, env=dict(os.environ, XDG_RUNTIME_DIR="/tmp"),
        )
        return json.loads(out.read_text())["results"][0]


def python_bench(ev, poses, cutoffs):
    """Poses per second and colliding count, timed as `bench` times."""
    times, hits = [], None
    while len(times) < 5 and sum(times) < 2.0:
        t = time.perf_counter()
        hits = ev.collides(poses, cutoffs, margin=0.0)
        times.append(time.perf_counter() - t)
    return len(poses) / float(np.median(times)), int(hits.sum())


def main():
    queries = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
    backend = sys.argv[2] if len(sys.argv) > 2 else "cpu"
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    scene = maamplan.Scene(str(DATA / "simple_curve"), **INPUTS)
    ev = maamplan.Evaluator(scene, backend=backend)
    poses, cutoffs = scene.sample_poses(queries, tilts=3)
    print(f"{len(poses)} poses, backend {ev.backend}")
    ratios = []
    for _ in range(rounds):
        cli = cli_bench(queries, backend)
        py, colliding = python_bench(ev, poses, cutoffs)
        ratios.append(cli["poses_per_second"] / py)
        print(f"maamplan bench {cli['poses_per_second']:>10.0f} poses/s (colliding {cli['colliding']}), "
              f"Evaluator.collides {py:>10.0f} poses/s (colliding {colliding}): {ratios[-1]:.2f}x")
        if colliding != cli["colliding"]:
            sys.exit("the colliding counts differ")
    print(f"bench / Python, median of {rounds}: {float(np.median(ratios)):.2f}x")


if __name__ == "__main__":
    main()
