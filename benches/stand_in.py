#!/usr/bin/env python3
"""A larger toolpath made from a data set model: the stand-in for the
held-back models in `benches/scale.sh` (BENCHMARKS.md, "Industrial scale").

Between two distinct waypoints of a layer file closer than GAP mm, three
are inserted at a quarter, a half and three quarters of the way, their
nozzle directions interpolated (then normalised). Layer surfaces are
copied as they are. dome_cut's 176,176 waypoints become 699,829.

Usage: benches/stand_in.py MODEL_DIR OUT_DIR
  e.g. benches/stand_in.py ../shared/datasets/zhang2021/dome_cut /tmp/dome_cut700k
"""
import math
import shutil
import sys
from pathlib import Path

GAP = 1.5
INSERTED = 3


def densified(lines):
    """The waypoint lines of one layer file with the inserted ones."""
    rows = [[float(x) for x in line.split()] for line in lines if line.strip()]
    out = []
    for k, row in enumerate(rows):
        out.append(row)
        if k + 1 == len(rows):
            break
        nxt = rows[k + 1]
        if not 0.0 < math.dist(row[:3], nxt[:3]) < GAP:
            continue
        for j in range(1, INSERTED + 1):
            t = j / (INSERTED + 1)
            p = [a + t * (b - a) for a, b in zip(row[:3], nxt[:3])]
            n = [a + t * (b - a) for a, b in zip(row[3:6], nxt[3:6])]
            length = math.hypot(*n) or 1.0
            out.append(p + [x / length for x in n])
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = Path(sys.argv[1]), Path(sys.argv[2])
    if not (src / "waypoint").is_dir():
        sys.exit(f"{src}: no waypoint/ folder (a data set model is expected)")
    (dst / "waypoint").mkdir(parents=True, exist_ok=True)
    total = 0
    for f in sorted((src / "waypoint").glob("*.txt")):
        rows = densified(f.read_text().splitlines())
        total += len(rows)
        text = "".join(" ".join(f"{x:.6g}" for x in r) + "\n" for r in rows)
        (dst / "waypoint" / f.name).write_text(text)
    if (src / "layer").is_dir():
        shutil.copytree(src / "layer", dst / "layer", dirs_exist_ok=True)
    print(f"{dst}: {total} waypoints")


if __name__ == "__main__":
    main()
