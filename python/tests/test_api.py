"""Shapes, dtypes, values and documentation of the API."""

import pydoc

import numpy as np
import pytest

import carom
from conftest import SMALL_PILE


@pytest.fixture(params=["lecture_100_k05", "box_3d"])
def world(request):
    w = carom.preset(request.param)
    w.step(20)
    return w


def test_arrays_have_the_documented_shapes_and_dtypes(world):
    n, d = len(world), world.dimensions
    assert d in (2, 3) and n > 0
    for name in ("positions", "velocities"):
        a = getattr(world, name)
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (n, d), name
    for name in ("radii", "masses"):
        a = getattr(world, name)
        assert a.dtype == np.float64 and a.shape == (n,), name
    assert world.momentum().dtype == np.float64 and world.momentum().shape == (d,)
    c = world.contacts()
    assert c.dtype == np.int64 and c.ndim == 2 and c.shape[1] == 2
    assert isinstance(world.kinetic_energy(), float)
    assert isinstance(world.potential_energy(), float)
    assert isinstance(world.time, float) and isinstance(world.steps, int)


def test_arrays_are_copies(world):
    x = world.positions
    x[:] = 0.0
    assert not np.all(world.positions == 0.0)


def test_time_steps_and_sums(world):
    assert world.steps == 20
    assert world.time == 20 * world.dt
    m, v = world.masses, world.velocities
    assert world.kinetic_energy() == pytest.approx(0.5 * np.sum(m * np.sum(v * v, axis=1)), rel=1e-12)
    np.testing.assert_allclose(world.momentum(), (m[:, None] * v).sum(axis=0), rtol=1e-9, atol=1e-9)
    world.step(0)
    assert world.steps == 20


def test_contacts_are_touching_pairs_in_id_order():
    world = carom.from_toml(SMALL_PILE)
    world.step(300)
    c = world.contacts()
    assert len(c) > 0
    assert np.all(c[:, 0] < c[:, 1])
    assert np.all(np.diff(c[:, 0] * len(world) + c[:, 1]) > 0), "sorted, no repeats"
    x, r = world.positions, world.radii
    gap = np.linalg.norm(x[c[:, 0]] - x[c[:, 1]], axis=1) - r[c[:, 0]] - r[c[:, 1]]
    assert np.all(gap < 0.05 * r[c[:, 0]]), "touching (within a step's motion)"
    assert carom.from_toml(SMALL_PILE).contacts().shape == (0, 2)


def test_observe_has_what_carom_run_observe_writes(world):
    o = world.observe()
    assert set(o) == {
        "step", "time", "kinetic_energy", "potential_energy",
        "temperature", "collisions", "pressure", "max_overlap",
    }
    assert o["step"] == 20 and o["time"] == world.time
    assert o["kinetic_energy"] == world.kinetic_energy()
    assert o["temperature"] > 0 and o["pressure"] > 0 and o["max_overlap"] >= 0
    world.step(30)
    assert world.observe()["collisions"] >= o["collisions"]


def test_the_deepest_overlap_is_over_every_pair():
    world = carom.from_toml(SMALL_PILE)

    def brute():
        x, r = world.positions, world.radii
        worst = 0.0
        for a in range(len(r)):
            d = np.linalg.norm(x[a + 1:] - x[a], axis=1)
            depth = (r[a] + r[a + 1:] - d) / np.minimum(r[a], r[a + 1:])
            worst = max([worst, *depth])
        return worst

    seen = 0.0
    for _ in range(12):
        assert world.deepest_overlap() == pytest.approx(brute(), abs=1e-12)
        seen = max(seen, world.deepest_overlap())
        world.step(25)
    assert seen > 0.0, "the pile must overlap somewhere for the test to mean anything"


def test_step_returns_what_the_steps_saw():
    world = carom.from_toml(SMALL_PILE)
    assert world.step(0) == {
        "steps": 0, "capped_steps": 0, "retaken_steps": 0, "collisions": 0,
        "max_overlap": 0.0, "asleep": 0, "pushing": 0,
    }
    seen = [world.step(100) for _ in range(6)]
    assert all(s["steps"] == 100 for s in seen)
    assert all(0 <= s["capped_steps"] <= 100 and 0 <= s["retaken_steps"] <= 100 for s in seen)
    assert all(isinstance(s["asleep"], int) for s in seen)
    # (the fill falls into a pile: impacts first, every disc asleep by the end, and the deepest
    # overlap of those states at least that of the state they end in)
    assert seen[0]["collisions"] > 0 and seen[0]["max_overlap"] > 0.0
    assert seen[-1]["asleep"] == 120
    # (the pile pushes while it settles; asleep, nothing does)
    assert seen[0]["pushing"] > 0 and seen[-1]["pushing"] == 0
    assert seen[-1]["max_overlap"] >= world.deepest_overlap()


COLUMN = "\n".join(
    ["dimensions = 2", "dt = 0.016666666666666666", "gravity = [0.0, -9.81]", "restitution = 0.5",
     "[domain]", "min = [-1.01, 0.0]", "max = [1.01, 40.0]", "walls = true"]
    + [f"[[particles]]\nposition = [0.0, {1.0 + 2.0 * k}]\nradius = 1.0" for k in range(10)]
)


def test_a_column_partly_asleep_pushes_only_where_awake():
    # (the Rust test of the same name: a sleeping column's top disc kicked up lands again)
    world = carom.from_toml(COLUMN)
    assert world.step(600)["asleep"] == 10
    v = world.velocities
    v[9] = [0.0, 3.0]
    world.set_velocities(v)
    partly = 0
    for _ in range(120):
        seen = world.step(1)
        awake = 10 - seen["asleep"]
        assert seen["pushing"] <= awake
        partly += 0 < seen["asleep"] and awake > 1 and seen["pushing"] == awake
    assert partly > 0
    assert world.step(1)["asleep"] == 10


def test_pressure_without_a_domain_is_nan():
    world = carom.preset("lecture_example_2")
    assert np.isnan(world.observe()["pressure"])


def test_presets_and_names():
    names = carom.presets()
    assert names[0] == "lecture_100_k05"
    assert {"lecture_100_k05", "lecture_5000_grid100", "box_3d"} <= set(names)
    for name in names:
        world = carom.preset(name)
        assert world.origin == f"preset:{name}" and world.steps == 0 and len(world) > 0
    assert carom.preset("lecture_5000_grid100").name == "Lecture demo: 5000 particles, hash grid 100x100"


def test_from_toml():
    world = carom.from_toml(
        """
        dimensions = 2
        dt = 0.01
        [[particles]]
        position = [0.0, 0.0]
        velocity = [1.0, 0.0]
        radius = 1.0
        mass = 2.0
        [[particles]]
        position = [3.0, 0.0]
        velocity = [-1.0, 0.0]
        radius = 1.0
        mass = 1.0
        """
    )
    assert world.origin == "<string>" and world.name is None and len(world) == 2
    p0 = world.momentum()
    world.step(100)
    np.testing.assert_allclose(world.momentum(), p0, atol=1e-12)
    assert world.positions[0, 0] < world.positions[1, 0]


def test_repr_says_what_the_world_is():
    world = carom.preset("lecture_100_k05")
    world.step(10)
    text = repr(world)
    for part in ("carom.World", "preset:lecture_100_k05", "2D", "100 particles", "step 10", "grid"):
        assert part in text, (part, text)


def test_help_reads_well():
    text = pydoc.render_doc(carom.World, renderer=pydoc.plaintext)
    for part in (
        "step(self, /, n=1)",
        "GIL",
        "KeyboardInterrupt",
        "positions",
        "(N, d)",
        "set_velocities",
        "write_csv",
        "checkpoint",
        "observe",
    ):
        assert part in text, part
    assert carom.__doc__ and "carom run" in carom.__doc__
    for f in (carom.load, carom.from_toml, carom.preset, carom.presets, carom.resume):
        assert f.__doc__, f


def test_stubs_ship_with_the_module():
    import importlib.resources as resources

    files = {p.name for p in resources.files("carom").iterdir()}
    assert "py.typed" in files and "__init__.pyi" in files
    stub = resources.files("carom").joinpath("__init__.pyi").read_text()
    for name in ("class World", "def step", "def load", "class SceneError", "def resume"):
        assert name in stub, name
