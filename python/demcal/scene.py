"""DEM scenes: a scene file (or a dict in its format) built and simulated in-process.

    s = demcal.Scene.load("examples/scenes/settle.toml")
    end = s.simulate(steps=2000)
    end.position.shape, end.kinetic_energy_j

Snapshots for ParaView are written by `demcal simulate`.
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Union

import numpy as np

from . import _demcal
from .errors import whole

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class SceneState:
    """Where a simulation ended: each particle's position and velocity (n x 3, m and m/s) and
    radius (m), the steps and simulated time, the kinetic energy, the wall time and, for a
    bonded scene, the bond counts (`bonds`, `intact`, `broken`)."""

    position: np.ndarray
    velocity: np.ndarray
    radius: np.ndarray
    steps: int
    simulated_s: float
    kinetic_energy_j: float
    wall_s: float
    particle_steps_per_s: float
    bonds: Optional[Dict[str, int]]

    @property
    def particles(self) -> int:
        return len(self.radius)


class Scene:
    """A DEM scene: the contents of a scene file as a dict. Relative paths in it are taken from
    `folder`."""

    def __init__(self, table: Mapping[str, Any], name: str = "scene", folder: PathLike = ".") -> None:
        self._table = copy.deepcopy(dict(table))
        self.name = name
        self.folder = os.fspath(folder)
        info = json.loads(_demcal.scene_info(json.dumps(self._table), self.name, self.folder))
        #: Particles at the start (factories add more while it runs).
        self.particles: int = info["particles"]
        self.geometries: int = info["geometries"]
        #: The time step (s) and the Rayleigh step it is a share of.
        self.time_step_s: float = info["time_step_s"]
        self.rayleigh_time_step_s: float = info["rayleigh_time_step_s"]
        #: The run length the file asks for, in steps.
        self.steps: int = info["steps"]
        self.contact_model: str = info["contact_model"]
        self.warnings: List[str] = list(info["warnings"])
        self.notes: List[str] = list(info["notes"])

    @classmethod
    def load(cls, path: PathLike) -> "Scene":
        """Reads and builds a scene file; errors name the file and the key (`InputError`)."""
        path = os.fspath(path)
        return cls(json.loads(_demcal.read_table(path)), name=path, folder=os.path.dirname(path) or ".")

    @classmethod
    def from_dict(cls, table: Mapping[str, Any], folder: PathLike = ".", name: str = "scene") -> "Scene":
        return cls(table, name=name, folder=folder)

    def to_dict(self) -> Dict[str, Any]:
        return copy.deepcopy(self._table)

    def simulate(self, steps: Optional[int] = None, threads: Optional[int] = None) -> SceneState:
        """Builds the scene anew and runs it for `steps` (the file's run length when None) on
        `threads` cores (all when None), with the GIL released; Ctrl-C stops it
        (`KeyboardInterrupt`). A run that blows up raises `DivergedError`."""
        steps = whole("steps", steps, 0)
        threads = whole("threads", threads, 1)
        a = json.loads(_demcal.scene_run(json.dumps(self._table), self.name, self.folder, steps, threads))
        return SceneState(
            position=np.asarray(a["position"], dtype=float).reshape(-1, 3),
            velocity=np.asarray(a["velocity"], dtype=float).reshape(-1, 3),
            radius=np.asarray(a["radius"], dtype=float),
            steps=int(a["steps"]),
            simulated_s=float(a["simulated_s"]),
            kinetic_energy_j=float(a["kinetic_energy_j"]),
            wall_s=float(a["wall_s"]),
            particle_steps_per_s=float(a["particle_steps_per_s"]),
            bonds=a["bonds"],
        )

    def __repr__(self) -> str:
        return f"Scene({self.name!r}, particles={self.particles}, steps={self.steps})"
