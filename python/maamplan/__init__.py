"""maamplan from Python: the collision evaluator, the planner and the
simulator of the maamplan crate, numpy arrays in and out.

Each call does what its command does, with the same defaults::

    import maamplan
    scene = maamplan.Scene("simple_curve", head="extruderHead.obj",
                           platform="printingPlatform.obj", place=(0, 0, 40.5))
    ev = maamplan.Evaluator(scene, backend="cpu")
    hits = ev.collides(scene.poses(), scene.cutoffs)      # maamplan check
    plan = maamplan.plan("simple_curve", head="extruderHead.obj",
                         platform="printingPlatform.obj", place=(0, 0, 40.5))
    plan.write("out")                                      # maamplan plan -o out
    sim = maamplan.simulate("program.gcode", head="extruderHead.obj")

Errors are ``MaamplanError``s: ``InputError`` for what the user can fix
(the command line's exit code 2), ``InternalError`` otherwise; the message
is the command line's one line.
"""

from ._maamplan import (
    Evaluator,
    InputError,
    InternalError,
    MaamplanError,
    Plan,
    Scene,
    Simulation,
    Toolpath,
    __version__,
    default_machine,
    plan,
    simulate,
)

__all__ = [
    "Evaluator",
    "InputError",
    "InternalError",
    "MaamplanError",
    "Plan",
    "Scene",
    "Simulation",
    "Toolpath",
    "__version__",
    "default_machine",
    "plan",
    "simulate",
]
