"""carom: a particle collision engine (the lecture "Collision Detection and Response", in 2D
and 3D), from Python.

Build a World from a scene (`load`, `from_toml`, `preset`) or a checkpoint (`resume`), step it
(`World.step`, with the GIL released) and read its state as numpy arrays. A world stepped here
gives the very bits `carom run` gives for the same scene and step count.

Units are the scene's own: lengths as its positions and radii, time as its `dt`, mass as its
masses.
"""

import os
from typing import Dict, List, Optional, Union, final

import numpy as np
import numpy.typing as npt

__all__ = ["SceneError", "World", "__version__", "from_toml", "load", "preset", "presets", "resume"]

__version__: str

_Path = Union[str, "os.PathLike[str]"]

class SceneError(ValueError):
    """A scene that could not be parsed or accepted.

    The message is the one `carom run` prints: the file (or `preset:NAME`, or `<string>` for
    `from_toml`), the field and what is wrong with it.
    """

    origin: str
    """The file the scene came from (its path as given), `preset:NAME` or `<string>`."""
    field: Optional[str]
    """The dotted path of the offending field, e.g. `particles[3].radius`; None when the
    problem is the whole file (malformed TOML, with its own line and column)."""

@final
class World:
    """A particle system built from a scene, stepped in time.

    Arrays are copies in id order (the scene's particles, explicit ones first, then each
    fill), float64 unless said otherwise. While `step` runs (without the GIL), any other use
    of the same world from another thread raises RuntimeError.
    """

    def step(self, n: int = 1) -> Dict[str, Union[int, float]]:
        """Advance by `n` time steps (`n * dt` time units), as `carom run` does. `n` is an int
        >= 0 (not a bool), at most 10^12 steps in all (the limit of `carom run --steps`).

        Returns what the steps saw, summed as `carom run`'s summary sums it: `steps`,
        `capped_steps` (velocity sweeps stopped at their cap), `retaken_steps` (taken again
        because a push drove a particle beyond its reach), `collisions`, `max_overlap` (the
        deepest overlap of any state passed through, a fraction of the smaller radius),
        `asleep` (particles asleep in the last step) and `pushing` (particle pairs that pushed
        each other in the last step: impacts and contacts carrying weight, overlapping or a
        hair apart).

        The GIL is released while the engine works. In the main thread, Ctrl-C
        (KeyboardInterrupt, or an exception raised by any signal handler) stops the loop
        between two steps: the exception propagates and the world is left at a whole step
        (`steps` says which).

        Raises ValueError for `n < 0`.
        """
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Particle positions, shape (N, d), id order (length units)."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """Particle velocities, shape (N, d), id order (length per time unit)."""
    @property
    def radii(self) -> npt.NDArray[np.float64]:
        """Particle radii, shape (N,), id order (length units)."""
    @property
    def masses(self) -> npt.NDArray[np.float64]:
        """Particle masses, shape (N,), id order (mass units)."""
    @property
    def time(self) -> float:
        """Simulated time so far, `steps * dt` (time units)."""
    @property
    def steps(self) -> int:
        """Steps taken so far (a resumed world counts those before its checkpoint)."""
    @property
    def dimensions(self) -> int:
        """2 or 3."""
    @property
    def dt(self) -> float:
        """The time step (time units)."""
    @property
    def name(self) -> Optional[str]:
        """The scene's `name`, or None."""
    @property
    def origin(self) -> str:
        """The scene's path as given to `load`, `preset:NAME`, or `<string>`."""
    @property
    def scene_steps(self) -> int:
        """The run's total steps: the scene's `steps` (what `carom run` runs when given no
        `--steps`), or for a resumed world the total of the run that wrote the checkpoint."""
    def __len__(self) -> int:
        """The number of particles, N."""
    def kinetic_energy(self) -> float:
        """Total kinetic energy `sum m |v|^2 / 2`, summed in id order."""
    def potential_energy(self) -> float:
        """Gravitational potential energy `sum -m g . x` (zero at the origin)."""
    def momentum(self) -> npt.NDArray[np.float64]:
        """Total momentum `sum m v`, shape (d,)."""
    def contacts(self) -> npt.NDArray[np.int64]:
        """The last step's touching pairs, shape (M, 2), ids `a < b`, sorted: those the
        lecture's detection finds overlapping (`distance < r1 + r2`) at the start of the
        step's velocity phase. (0, 2) before the first step. Pairs of sleeping particles are the remembered resting
        contacts that overlap."""
    def deepest_overlap(self) -> float:
        """The deepest particle-particle overlap in the state as it is, over every pair, as a
        fraction of the smaller radius (0.0 when nothing overlaps); what `carom run` prints
        "at the end"."""
    def observe(self) -> Dict[str, Union[int, float]]:
        """One row of `carom run --observe`: `step`, `time`, `kinetic_energy`,
        `potential_energy`, `temperature`, `collisions` (since the first reading), `pressure`
        (over the interval since the previous reading; NaN without a domain), `max_overlap`
        (fraction of the smaller radius).

        Each call closes the pressure's interval; the first one starts the counts. Call it at
        step 0 and after every `step(K)` for the CLI's rows with `--every K`.
        """
    def set_velocities(self, velocities: npt.ArrayLike) -> None:
        """Replace every velocity: array-like of shape (N, d), finite, in id order.

        Raises ValueError naming the problem (and changes nothing) otherwise.
        """
    def write_csv(self, path: _Path) -> None:
        """Write the state CSV `carom run --out` writes (`id,x,y,vx,vy,radius,mass`, 3D with
        z and vz), atomically. Raises OSError if it cannot."""
    def checkpoint(self, path: _Path) -> None:
        """Write a checkpoint (`carom run --checkpoint`'s format), atomically; continue it
        with `carom.resume(path)` or `carom resume PATH`. Raises OSError if it cannot."""

def load(path: _Path) -> World:
    """The world of the scene file at `path`, as `carom run PATH` builds it.

    Raises SceneError for an invalid scene, OSError for an unreadable file.
    """

def from_toml(text: str) -> World:
    """The world of a scene given as TOML text; messages name it `<string>`.

    Raises SceneError for an invalid scene.
    """

def preset(name: str) -> World:
    """The world of a built-in scene, as `carom run --preset NAME` builds it.

    Raises ValueError for an unknown name.
    """

def presets() -> List[str]:
    """The names of the built-in scenes, in order (the first is `carom run`'s default)."""

def resume(checkpoint_path: _Path) -> World:
    """The world a checkpoint holds, as `carom resume` rebuilds it: stepping on gives the bits
    of the run that was never stopped.

    Raises OSError for an unreadable file, ValueError for a damaged or foreign one, SceneError
    if the scene inside is no longer valid.
    """
