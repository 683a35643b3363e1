"""The lecture's two demos, run from Python and plotted with matplotlib.

- `lecture_100_k05`: 100 particles of radius 4 in a walled box under gravity, restitution
  k = 0.5: they lose energy at every impact and settle into a pile.
- `lecture_5000_grid100`: 5000 particles of radius 1, k = 1, found by the lecture's hash grid
  (100 x 100 cells): an elastic gas under gravity, whose energy stays put.

    pip install ./python matplotlib        # from the repository root
    python python/examples/lecture_demos.py [OUT.png]

It writes one figure (default `lecture_demos.png`): each demo at its start and its end, and
its energies over time.
"""

import sys
import time

import matplotlib

matplotlib.use("Agg")  # no window needed: the figure goes to a file
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import EllipseCollection

import carom


def run(world, steps, every):
    """Steps `world` to `steps`, reading its observables every `every` steps; returns the
    start and end states and the readings."""
    start = (world.positions, world.velocities, world.radii)
    readings = [world.observe()]
    began = time.perf_counter()
    while world.steps < steps:
        world.step(min(every, steps - world.steps))
        readings.append(world.observe())
    seconds = time.perf_counter() - began
    print(f"{world.name}: {steps} steps in {seconds:.2f} s ({seconds / steps * 1e3:.3f} ms per step)")
    end = (world.positions, world.velocities, world.radii)
    series = {key: np.array([r[key] for r in readings]) for key in readings[0]}
    return start, end, series


def draw_particles(ax, state, title, box=100.0, vmax=None):
    """The particles as circles of their true radii, coloured by speed."""
    x, v, r = state
    speed = np.linalg.norm(v, axis=1)
    circles = EllipseCollection(
        2 * r, 2 * r, np.zeros_like(r), units="xy", offsets=x,
        offset_transform=ax.transData, cmap="viridis", linewidths=0,
    )
    circles.set_array(speed)
    circles.set_clim(0, vmax if vmax is not None else max(speed.max(), 1e-9))
    ax.add_collection(circles)
    ax.set_xlim(-box, box)
    ax.set_ylim(-box, box)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=10)
    return circles


def draw_energies(ax, series, title):
    t = series["time"]
    kinetic, potential = series["kinetic_energy"], series["potential_energy"]
    # potential energy has an arbitrary zero: show it from its value at the start
    total = kinetic + potential - potential[0]
    ax.plot(t, kinetic, label="kinetic")
    ax.plot(t, potential - potential[0], label="potential (from its start)")
    ax.plot(t, total, label="kinetic + potential", color="black", linewidth=1.5)
    ax.set_xlabel("time")
    ax.set_ylabel("energy")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)


def main(out="lecture_demos.png"):
    fig, axes = plt.subplots(2, 3, figsize=(15, 9.5), constrained_layout=True)
    demos = [
        ("lecture_100_k05", "100 particles, k = 0.5"),
        ("lecture_5000_grid100", "5000 particles, k = 1, grid 100 x 100"),
    ]
    for row, (name, label) in zip(axes, demos):
        world = carom.preset(name)
        steps = world.scene_steps  # what `carom run --preset NAME` runs
        start, end, series = run(world, steps, every=20)
        vmax = max(np.linalg.norm(state[1], axis=1).max() for state in (start, end))
        draw_particles(row[0], start, f"{label}: t = 0", vmax=vmax)
        circles = draw_particles(row[1], end, f"{label}: t = {world.time:g}", vmax=vmax)
        fig.colorbar(circles, ax=row[:2], shrink=0.8, label="speed")
        drop = series["kinetic_energy"][-1] / series["kinetic_energy"][0]
        draw_energies(
            row[2], series,
            f"{label}: energies\n{series['collisions'][-1]} collisions, "
            f"kinetic energy x {drop:.3g} at the end",
        )
    fig.suptitle("carom from Python: the lecture's demos (carom.preset(...).step(...))")
    fig.savefig(out, dpi=80)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
