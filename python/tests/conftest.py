"""Where the suite finds the command line it compares against and the
data set: ``MAAMPLAN_BIN`` (default: the release build of this checkout)
and ``MAAMPLAN_DATASET`` (default: ../shared/datasets/zhang2021 beside the
checkout)."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("MAAMPLAN_BIN", ROOT / "target" / "release" / "maamplan"))
DATA = Path(
    os.environ.get("MAAMPLAN_DATASET", ROOT.parent / "shared" / "datasets" / "zhang2021")
)
# simple_curve as the README's commands place it.
SIMPLE = dict(
    head=str(DATA / "extruderHead.obj"),
    platform=str(DATA / "printingPlatform.obj"),
    place=(0.0, 0.0, 40.5),
)
SIMPLE_ARGS = [
    "--head", SIMPLE["head"], "--platform", SIMPLE["platform"], "--place", "0,0,40.5",
]


def cli(*args, check=True):
    """Run the command line; its completed process."""
    env = dict(os.environ, XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp"))
    done = subprocess.run(
        [str(BIN), *map(str, args)], capture_output=True, text=True, env=env
    )
    if check and done.returncode != 0:
        raise AssertionError(f"maamplan {' '.join(map(str, args))}: {done.stderr}")
    return done


def cli_json(path):
    return json.loads(Path(path).read_text())


@pytest.fixture(scope="session", autouse=True)
def inputs_present():
    missing = [p for p in (BIN, DATA / "simple_curve") if not p.exists()]
    if missing:
        pytest.fail(
            f"missing {', '.join(map(str, missing))}: build with `cargo build --release` "
            "and put the data set at ../shared/datasets/zhang2021"
        )


@pytest.fixture(scope="session")
def simple_scene():
    import maamplan

    return maamplan.Scene(str(DATA / "simple_curve"), **SIMPLE)
