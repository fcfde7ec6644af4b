"""Type stubs of the Rust extension; ``maamplan`` re-exports all of it."""

import os
from typing import Any, Callable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
#: A mesh: a file (OBJ, STL, glTF), ``(vertices (V, 3), faces (F, 3))``
#: arrays, or an object with ``vertices`` and ``faces`` (trimesh.Trimesh).
MeshLike = Union[PathLike, Tuple[npt.ArrayLike, npt.ArrayLike], Any]
#: ``progress(stage, done, total)``: a stage begins (0, 0) or ``done`` of
#: ``total`` collision queries are answered.
Progress = Callable[[str, int, int], Any]

class MaamplanError(Exception):
    """Base class of every error maamplan raises; its message is the
    command line's one-line message."""

class InputError(MaamplanError):
    """A problem with an input or an argument the user can fix (the
    command line's exit code 2)."""

class InternalError(MaamplanError):
    """A failure inside maamplan (the command line's exit code 1)."""

class Toolpath:
    """A toolpath: a folder (``waypoint/<k>.txt``, ``layer/<k>.obj``), a
    single waypoint file, a G-code program, arrays, or the built-in
    example."""

    def __init__(self, path: PathLike) -> None: ...
    @staticmethod
    def default() -> "Toolpath":
        """The built-in example job, the command line's default."""
    @staticmethod
    def from_arrays(
        positions: npt.ArrayLike,
        directions: npt.ArrayLike,
        layer: Optional[npt.ArrayLike] = None,
        surfaces: Optional[Sequence[MeshLike]] = None,
    ) -> "Toolpath":
        """Tips (N, 3) and nozzle axes (N, 3) in print order, mm; ``layer``
        (N,) integers (consecutive equal values are one layer; None: one
        layer, then found from how the beads stack); ``surfaces``: one mesh
        per layer, or None (the part is modelled from the beads)."""
    @property
    def path(self) -> Optional[str]: ...

ToolpathLike = Union[Toolpath, PathLike, None]

class Scene:
    """The toolpath (the command line's conventions applied), the head,
    the platform and the part printed so far, as ``check`` loads them."""

    def __init__(
        self,
        toolpath: ToolpathLike = None,
        head: Optional[MeshLike] = None,
        platform: Optional[MeshLike] = None,
        *,
        place: Optional[Tuple[float, float, float]] = None,
        y_up: bool = False,
        tilt: Optional[float] = None,
        keep_normals: bool = False,
        clearance: float = 0.3,
        part: str = "auto",
        machine: Optional[PathLike] = None,
    ) -> None: ...
    @property
    def source(self) -> str: ...
    @property
    def part(self) -> str:
        """What the part is modelled from ("surfaces", "beads", ...)."""
    @property
    def triangle_count(self) -> int: ...
    @property
    def margin(self) -> float:
        """The machine's safety margin (mm), ``collides``' default."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Nozzle tips (N, 3), mm, as loaded."""
    @property
    def directions(self) -> npt.NDArray[np.float64]:
        """Nozzle axes (N, 3), as loaded."""
    @property
    def layer(self) -> npt.NDArray[np.int64]:
        """Layer index per waypoint (N,)."""
    @property
    def layer_names(self) -> list[str]: ...
    @property
    def flipped_layers(self) -> list[str]:
        """Layers whose nozzle axes were reversed on loading."""
    @property
    def cutoffs(self) -> npt.NDArray[np.uint32]:
        """Per waypoint: a pose there is checked against what was printed
        before it."""
    def poses(self) -> npt.NDArray[np.float64]:
        """Every waypoint's head pose (N, 4, 4) as ``check`` poses it (the
        machine's kinematics, direct IK); ``x_part = R @ x_head + tip``."""
    def sample_poses(
        self, count: int = 20000, tilts: int = 3
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.uint32]]:
        """``bench``'s queries: ``count`` poses (waypoints evenly strided,
        each in its own orientation and ``tilts`` tilted variants) and
        their cutoffs."""

class Evaluator:
    """A collision evaluator over a scene."""

    def __init__(self, scene: Scene, backend: str = "auto") -> None:
        """``backend``: "auto" (a hardware GPU, else the CPU), "gpu" (any
        adapter, software ones included), "cpu" or "parry"."""
    @property
    def backend(self) -> str: ...
    def summary(self) -> Optional[str]: ...
    def collides(
        self,
        poses: Union[npt.ArrayLike, Tuple[npt.ArrayLike, npt.ArrayLike]],
        cutoffs: Optional[npt.ArrayLike] = None,
        margin: Optional[float] = None,
        progress: Optional[Progress] = None,
    ) -> npt.NDArray[np.bool_]:
        """For each pose ((N, 4, 4) transforms, or (tips (N, 3), nozzle
        axes (N, 3))): does the head come closer than ``margin`` mm (None:
        the machine's) to the platform or the part printed before its
        cutoff (None: the whole part)?"""

class Plan:
    """A plan: axes and flags per waypoint (plan.csv's columns)."""

    @property
    def axes(self) -> npt.NDArray[np.float64]:
        """(N, 5): X, Y, Z mm, B (or A), C degrees; NaN where skipped."""
    @property
    def input_axes(self) -> npt.NDArray[np.float64]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def directions(self) -> npt.NDArray[np.float64]: ...
    @property
    def layer(self) -> npt.NDArray[np.int64]: ...
    @property
    def layer_names(self) -> list[str]: ...
    @property
    def e(self) -> npt.NDArray[np.float64]: ...
    @property
    def height(self) -> npt.NDArray[np.float64]: ...
    @property
    def section_start(self) -> npt.NDArray[np.bool_]: ...
    @property
    def break_before(self) -> npt.NDArray[np.bool_]: ...
    @property
    def was_colliding(self) -> npt.NDArray[np.bool_]: ...
    @property
    def was_singular(self) -> npt.NDArray[np.bool_]: ...
    @property
    def singular(self) -> npt.NDArray[np.bool_]: ...
    @property
    def skipped(self) -> npt.NDArray[np.bool_]: ...
    @property
    def skip_reasons(self) -> list[Optional[str]]: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def backend(self) -> str: ...
    @property
    def report(self) -> dict[str, Any]:
        """report.json's content."""
    def csv(self) -> str:
        """plan.csv's text."""
    def write(self, dir: PathLike, plots: bool = True) -> str:
        """Write the command line's outputs into ``dir`` at once."""

class Simulation:
    """A simulated program: per moving line, its measures."""

    @property
    def line(self) -> npt.NDArray[np.int64]: ...
    @property
    def extrudes(self) -> npt.NDArray[np.bool_]: ...
    @property
    def tcp(self) -> npt.NDArray[np.bool_]: ...
    @property
    def layer(self) -> npt.NDArray[np.int64]: ...
    @property
    def seconds(self) -> npt.NDArray[np.float64]: ...
    @property
    def length_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def tip_speed(self) -> npt.NDArray[np.float64]: ...
    @property
    def deviation_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def rotary_step_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def tilt_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def c_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def e_per_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def collides(self) -> npt.NDArray[np.bool_]: ...
    @property
    def colliding_lines(self) -> npt.NDArray[np.int64]: ...
    @property
    def problems(self) -> list[dict[str, Any]]:
        """``line``, ``kind``, ``value``, ``layer`` and ``time_s`` (its time in program.glb) per problem."""
    @property
    def summary(self) -> dict[str, Any]: ...
    @property
    def report(self) -> dict[str, Any]:
        """report.json's content, as ``simulate -o`` writes it."""
    @property
    def against(self) -> str: ...

def plan(
    toolpath: ToolpathLike = None,
    *,
    head: Optional[MeshLike] = None,
    platform: Optional[MeshLike] = None,
    place: Optional[Tuple[float, float, float]] = None,
    y_up: bool = False,
    tilt: Optional[float] = None,
    keep_normals: bool = False,
    clearance: float = 0.3,
    part: str = "auto",
    machine: Optional[PathLike] = None,
    backend: str = "auto",
    margin: Optional[float] = None,
    smoothing: str = "laplacian",
    passes: int = 8,
    window: int = 9,
    cone: float = 15.0,
    alpha: float = 4.5,
    beta: float = 45.0,
    variants: int = 24,
    rings: bool = False,
    subsample: int = 1,
    edge_step: float = 0.3,
    progress: Optional[Progress] = None,
) -> Plan:
    """``maamplan plan``, with its defaults."""

def simulate(
    program: PathLike,
    toolpath: ToolpathLike = None,
    *,
    head: Optional[MeshLike] = None,
    platform: Optional[MeshLike] = None,
    place: Optional[Tuple[float, float, float]] = None,
    y_up: bool = False,
    tilt: Optional[float] = None,
    keep_normals: bool = False,
    clearance: float = 0.3,
    part: str = "auto",
    machine: Optional[PathLike] = None,
    backend: str = "auto",
    margin: Optional[float] = None,
    progress: Optional[Progress] = None,
) -> Simulation:
    """``maamplan simulate``, with its defaults (None toolpath: against the
    beads the program lays itself)."""

def default_machine() -> str:
    """The built-in machine as a machine file's TOML text."""
