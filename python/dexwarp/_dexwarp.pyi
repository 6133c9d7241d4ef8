"""Type stubs of the extension module ``dexwarp._dexwarp`` (see ``python/src``)."""

import os
import pathlib
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "os.PathLike[str]"]
_Array = npt.ArrayLike
_F64 = npt.NDArray[np.float64]

class DexwarpError(Exception):
    """An input dexwarp refuses, or a run that failed.

    ``str(err)`` is the command line's message (file, field, what was expected); ``path``
    and ``field`` hold the first two (None when the error has none)."""

    path: Optional[str]
    field: Optional[str]

class Demo:
    """A demonstration (``dexwarp.demo/1``); immutable."""

    @staticmethod
    def load(path: _Path) -> Demo:
        """Reads and validates a demonstration file (paths inside relative to it)."""
    @staticmethod
    def from_arrays(
        *,
        name: str,
        fps: float,
        robot: _Path,
        object_mesh: _Path,
        object_mass: float,
        joint_names: Sequence[str],
        object_positions: _Array,
        object_quaternions: _Array,
        wrist_positions: _Array,
        wrist_quaternions: _Array,
        joints: _Array,
        contact_frames: Optional[_Array] = None,
        contact_links: Optional[Sequence[str]] = None,
        contact_hand_points: Optional[_Array] = None,
        contact_object_points: Optional[_Array] = None,
        object_name: Optional[str] = None,
        scene: Optional[_Path] = None,
        barriers: Optional[Sequence[str]] = None,
    ) -> Demo:
        """A demonstration from arrays (T frames, D joints, K contacts), checked as a file.

        object_positions (T, 3) [m], object_quaternions (T, 4) [w, x, y, z],
        wrist_positions (T, 3), wrist_quaternions (T, 4), joints (T, D) in the order of
        joint_names; one row per contact: contact_frames (K,), contact_links (K names),
        contact_hand_points (K, 3) in the link frame, contact_object_points (K, 3) in the
        object frame. Paths relative to the current folder; errors name ``<arrays>``."""
    def save(self, path: _Path) -> None:
        """Writes a ``dexwarp.demo/1`` file atomically."""
    def __len__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def fps(self) -> float:
        """Frame rate [Hz]."""
    @property
    def source(self) -> pathlib.Path:
        """The file it was read from (``<arrays>`` when built from arrays)."""
    @property
    def robot(self) -> pathlib.Path:
        """URDF of the hand."""
    @property
    def object_mesh(self) -> pathlib.Path: ...
    @property
    def object_name(self) -> str: ...
    @property
    def object_mass(self) -> float:
        """[kg]"""
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def scene(self) -> Optional[pathlib.Path]: ...
    @property
    def barriers(self) -> list[str]: ...
    @property
    def object_positions(self) -> _F64:
        """(T, 3) [m]"""
    @property
    def object_quaternions(self) -> _F64:
        """(T, 4) [w, x, y, z]"""
    @property
    def wrist_positions(self) -> _F64:
        """(T, 3) [m]"""
    @property
    def wrist_quaternions(self) -> _F64:
        """(T, 4) [w, x, y, z]"""
    @property
    def joints(self) -> _F64:
        """(T, D), columns as joint_names."""
    @property
    def contact_frames(self) -> npt.NDArray[np.int64]:
        """(K,) frame of each correspondence."""
    @property
    def contact_links(self) -> list[str]: ...
    @property
    def contact_hand_points(self) -> _F64:
        """(K, 3) in the link frame [m]."""
    @property
    def contact_object_points(self) -> _F64:
        """(K, 3) in the object frame [m]."""
    @property
    def timewarp(self) -> Optional[_F64]:
        """τ of a warped output (one output time per input frame), else None."""

class Config:
    """A warp config (``dexwarp.config/1``); immutable."""

    @staticmethod
    def load(path: _Path) -> Config:
        """Reads and validates a config file (paths inside relative to it)."""
    @staticmethod
    def from_dict(data: dict[str, Any], *, path: Optional[_Path] = None) -> Config:
        """A config from a dict with a config file's fields (``format`` and ``demo`` may be
        left out), checked as that file would be; paths relative to the folder of ``path``
        (default: the current folder); errors name ``path`` or ``<dict>``."""
    def to_dict(self) -> dict[str, Any]:
        """The config's fields as in its file."""
    @property
    def name(self) -> str: ...
    @property
    def demo(self) -> Optional[pathlib.Path]:
        """The demonstration it was written for, or None."""
    @property
    def scene(self) -> pathlib.Path: ...
    @property
    def barriers(self) -> list[str]: ...
    @property
    def source(self) -> pathlib.Path: ...

class Result:
    """What one warp produced."""

    @property
    def demo(self) -> Demo:
        """The warped demonstration (with timewarp)."""
    @property
    def report(self) -> dict[str, Any]:
        """``report.json`` as ``dexwarp warp`` writes it (``outputs`` only after save)."""
    @property
    def object_positions(self) -> _F64:
        """(T_out, 3) [m]"""
    @property
    def object_quaternions(self) -> _F64:
        """(T_out, 4) [w, x, y, z]"""
    @property
    def wrist_positions(self) -> _F64:
        """(T_out, 3) [m]"""
    @property
    def wrist_quaternions(self) -> _F64:
        """(T_out, 4) [w, x, y, z]"""
    @property
    def joints(self) -> _F64:
        """(T_out, D), columns as demo.joint_names."""
    @property
    def tau(self) -> _F64:
        """(T_in,) output frame time of each input frame."""
    def save(self, dir: _Path) -> dict[str, Any]:
        """Writes DIR/<name>.demo.json, frames.csv, report.json as one set; the report."""

def warp(
    demo: Demo,
    config: Config,
    *,
    threshold_mm: Optional[float] = None,
    hand: str = "contact",
    solver: str = "lm",
    physics: bool = True,
    objective: Optional[str] = None,
    penetration_weight: Optional[float] = None,
    warm_start: Optional[str] = None,
) -> Result:
    """Warps demo with config (``dexwarp warp``), GIL released.

    hand: "contact" | "baseline"; solver: "lm" | "adam"; objective: "non_penetrating" |
    "paper"; warm_start: "follow_object" | "previous" | "rigid"; physics=False skips the replay."""

def validate(
    demo: Demo, *, scene: Optional[_Path] = None, barriers: Optional[Sequence[str]] = None
) -> dict[str, Any]:
    """Physics replay and report of any demonstration (``dexwarp validate``)."""

def augment(
    demo: _Path,
    variations: _Path,
    *,
    count: int,
    out: _Path,
    seed: int = 0,
    jobs: int = 0,
    shard: Optional[str] = None,
    force: bool = False,
    compare_baseline: bool = False,
    margin: bool = False,
) -> dict[str, Any]:
    """``dexwarp augment``: N sampled variations run with physics into out/; stats.json.
    ``compare_baseline`` also runs each sample with the SE(3) baseline hand
    (``stats["baseline"]``: its yield and the paired counts); ``margin`` also measures the
    robustness margin of every sample that passes physics (``stats["robust"]``)."""
