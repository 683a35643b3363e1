"""A World stepped from Python gives the very bits `carom run` gives (the CLI under test is
the debug build `cargo test` leaves, the module a release build: same bits)."""

import numpy as np
import pytest

import carom
from conftest import SCENES, assert_same_state, bits

CASES = [
    # (how the CLI names the scene, how Python loads it, steps)
    (["--preset", "lecture_100_k05"], lambda: carom.preset("lecture_100_k05"), 400),
    (["--preset", "lecture_5000_grid100"], lambda: carom.preset("lecture_5000_grid100"), 30),
    (["--preset", "box_3d"], lambda: carom.preset("box_3d"), 150),
    (["--preset", "lecture_pile_60hz"], lambda: carom.preset("lecture_pile_60hz"), 40),
    ([SCENES / "periodic_gas.toml"], lambda: carom.load(SCENES / "periodic_gas.toml"), 60),
    ([SCENES / "newton_cradle_3d.toml"], lambda: carom.load(str(SCENES / "newton_cradle_3d.toml")), 200),
]


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = np.array([[float(x) for x in line.split(",")] for line in f])
    return header, rows


@pytest.mark.parametrize(
    "cli_scene,make,steps", CASES, ids=[str(c[0][-1]).split("/")[-1] for c in CASES]
)
def test_same_bits_as_carom_run(cli, tmp_path, cli_scene, make, steps):
    expected = tmp_path / "cli.csv"
    cli("run", *cli_scene, "--steps", steps, "--out", expected)
    world = make()
    world.step(steps)
    got = tmp_path / "python.csv"
    world.write_csv(got)
    assert got.read_bytes() == expected.read_bytes()
    # and the arrays hold what the CSV says, bit for bit
    header, rows = read_csv(expected)
    d = world.dimensions
    assert header[0] == "id" and len(header) == 2 * d + 3
    np.testing.assert_array_equal(rows[:, 0], np.arange(len(world)))
    np.testing.assert_array_equal(bits(world.positions), bits(rows[:, 1 : 1 + d]))
    np.testing.assert_array_equal(bits(world.velocities), bits(rows[:, 1 + d : 1 + 2 * d]))
    np.testing.assert_array_equal(bits(world.radii), bits(rows[:, -2]))
    np.testing.assert_array_equal(bits(world.masses), bits(rows[:, -1]))


def test_steps_in_pieces_equal_one_call():
    whole = carom.preset("lecture_100_k05")
    whole.step(250)
    pieces = carom.preset("lecture_100_k05")
    for n in (1, 0, 9, 40, 199):
        pieces.step(n)
    pieces.step()
    assert_same_state(whole, pieces)


def test_same_bits_through_a_pile_falling_asleep(cli, tmp_path, small_pile):
    # resting contacts, warm-started impulses, rest timers and sleeping particles
    cli("run", small_pile, "--steps", 450, "--out", tmp_path / "cli.csv")
    world = carom.load(small_pile)
    world.step(450)
    world.write_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()


def test_default_run_of_a_scene(cli, tmp_path):
    # `carom run` with no --steps runs the scene's own `steps`
    expected = tmp_path / "cli.csv"
    cli("run", "--preset", "lecture_example_2", "--out", expected)
    world = carom.preset("lecture_example_2")
    world.step(world.scene_steps)
    world.write_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == expected.read_bytes()


def test_observe_gives_the_rows_of_carom_run_observe(cli, tmp_path):
    every, steps = 50, 300
    path = tmp_path / "observe.csv"
    cli("run", "--preset", "lecture_100_k05", "--steps", steps, "--observe", path, "--every", every)
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    world = carom.preset("lecture_100_k05")
    readings = [world.observe()]
    while world.steps < steps:
        world.step(every)
        readings.append(world.observe())
    assert len(readings) == len(lines) - 1
    for line, reading in zip(lines[1:], readings):
        for name, text in zip(header, line.split(",")):
            value = reading[name]
            if name in ("step", "collisions"):
                assert type(value) is int and value == int(text), name
            else:
                assert type(value) is float
                assert bits(value) == bits(float(text)), (name, value, text)
    assert readings[-1]["collisions"] > 0


@pytest.mark.parametrize("at", [120, 330, 400])  # falling, resting, asleep
def test_checkpoint_then_resume_equals_a_straight_run(tmp_path, small_pile, at):
    straight = carom.load(small_pile)
    straight.step(450)
    first = carom.load(small_pile)
    first.step(at)
    first.observe()  # the observables' sums travel too
    first.checkpoint(tmp_path / "run.ckpt")
    again = carom.resume(tmp_path / "run.ckpt")
    assert again.steps == at and again.origin == str(small_pile)
    again.step(450 - at)
    assert_same_state(straight, again)
    # and the world checkpointed goes on as if nothing happened
    first.step(450 - at)
    assert_same_state(straight, first)
    assert again.observe() == first.observe()


def test_checkpoint_matches_the_cli_byte_for_byte(cli, tmp_path):
    # `carom run` with no --steps runs the scene's 2000 steps and keeps them as its total
    cli("run", "--preset", "lecture_100_k05", "--checkpoint", tmp_path / "cli.ckpt", "--checkpoint-every", 2000)
    world = carom.preset("lecture_100_k05")
    world.step(world.scene_steps)
    world.checkpoint(tmp_path / "py.ckpt")
    assert (tmp_path / "py.ckpt").read_bytes() == (tmp_path / "cli.ckpt").read_bytes()


def test_cli_checkpoint_resumed_in_python_and_back(cli, tmp_path):
    straight = tmp_path / "straight.csv"
    cli("run", "--preset", "box_3d", "--steps", 200, "--out", straight)
    # the CLI stops at 80; Python carries on
    cli("run", "--preset", "box_3d", "--steps", 80, "--checkpoint", tmp_path / "cli.ckpt", "--checkpoint-every", 80)
    world = carom.resume(tmp_path / "cli.ckpt")
    assert world.steps == 80 and world.dimensions == 3
    world.step(120)
    world.write_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == straight.read_bytes()
    # Python stops at 130; the CLI carries on
    world = carom.preset("box_3d")
    world.step(130)
    world.checkpoint(tmp_path / "py.ckpt")
    cli("resume", tmp_path / "py.ckpt", "--steps", 200, "--out", tmp_path / "cli.csv")
    assert (tmp_path / "cli.csv").read_bytes() == straight.read_bytes()


def test_resume_keeps_the_cli_overrides(cli, tmp_path):
    # a run with --broadphase/--cells: the checkpoint carries them, and resume applies them
    args = ["--preset", "lecture_5000_grid100", "--broadphase", "grid", "--cells", "40,40"]
    cli("run", *args, "--steps", 20, "--out", tmp_path / "straight.csv")
    cli("run", *args, "--steps", 10, "--checkpoint", tmp_path / "cli.ckpt", "--checkpoint-every", 10)
    world = carom.resume(tmp_path / "cli.ckpt")
    world.step(10)
    assert "grid" in repr(world)
    world.write_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "straight.csv").read_bytes()


def test_set_velocities_matches_the_same_scene_with_those_velocities():
    # setting the velocities a world already has wakes it and changes nothing else: the
    # scene's particles start awake, so stepping on gives the same bits
    world = carom.preset("lecture_100_k05")
    other = carom.preset("lecture_100_k05")
    other.set_velocities(other.velocities)
    world.step(100)
    other.step(100)
    assert_same_state(world, other)
    v = world.velocities * 0.5
    world.set_velocities(v)
    np.testing.assert_array_equal(bits(world.velocities), bits(v))
    world.set_velocities(v.tolist())  # any array-like
    np.testing.assert_array_equal(bits(world.velocities), bits(v))
