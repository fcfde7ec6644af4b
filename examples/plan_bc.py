# %% [markdown]
# # Plan a toolpath and look at its rotary axes
#
# A notebook-style script (run it whole, or cell by cell in an editor that
# reads `# %%` cells): load simple_curve from the data set, plan it for
# the built-in machine, and plot B and C per layer, input against plan.
# Needs `pip install ./python matplotlib`.

# %%
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import maamplan

DATA = Path(__file__).resolve().parents[2] / "shared" / "datasets" / "zhang2021"
OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("plan_bc")

# %% Load the toolpath and see what the machine's own poses would hit.
toolpath = maamplan.Toolpath(DATA / "simple_curve")
inputs = dict(
    head=DATA / "extruderHead.obj",
    platform=DATA / "printingPlatform.obj",
    place=(0.0, 0.0, 40.5),
)
scene = maamplan.Scene(toolpath, **inputs)
hits = maamplan.Evaluator(scene).collides(scene.poses(), scene.cutoffs)
print(f"{scene}: {hits.sum()} waypoints collide as given")

# %% Plan it (what `maamplan plan` does), reporting the stages as they go.
plan = maamplan.plan(toolpath, progress=lambda stage, done, total: None, **inputs)
print(plan, plan.report["plan"]["residual_collisions"], "residual collisions")
plan.write(OUT / "out", plots=False)

# %% B and C per layer: the input (direct IK) grey, the plan blue.
layers = np.unique(plan.layer)
shown = layers[np.linspace(0, len(layers) - 1, min(6, len(layers))).astype(int)]
fig, axs = plt.subplots(len(shown), 2, figsize=(10, 2.2 * len(shown)), squeeze=False)
for row, k in zip(axs, shown):
    at = plan.layer == k
    for ax, col, name in ((row[0], 3, "B"), (row[1], 4, "C")):
        ax.plot(plan.input_axes[at, col], color="0.6", lw=0.8, label="input")
        ax.plot(plan.axes[at, col], color="tab:blue", lw=0.8, label="plan")
        ax.set_ylabel(f"{name} (°), layer {plan.layer_names[k]}")
axs[0][0].legend()
for ax in axs[-1]:
    ax.set_xlabel("waypoint of the layer")
fig.tight_layout()
OUT.mkdir(parents=True, exist_ok=True)
fig.savefig(OUT / "bc_per_layer.png", dpi=90)
print(f"wrote {OUT / 'bc_per_layer.png'}")
