"""Shared fixtures: the `carom` binary to compare with, and helpers."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


# 120 discs poured into a small walled box at dt = 1/60: resting contacts from about step 250,
# the whole pile asleep from step 385 (a cheap stand-in for `lecture_pile_60hz`).
SMALL_PILE = """
name = "A small pile at dt = 1/60"
dimensions = 2
dt = 0.016666666666666666
steps = 600
gravity = [0.0, -9.81]
restitution = 0.5

[domain]
min = [-15.0, -15.0]
max = [15.0, 15.0]
walls = true

[[fill]]
count = 120
radius = 1.0
mass = 1.0
speed = 2.0
seed = 7
"""


@pytest.fixture
def small_pile(tmp_path):
    """The path of a file holding SMALL_PILE."""
    path = tmp_path / "small_pile.toml"
    path.write_text(SMALL_PILE)
    return path


def _find_binary():
    given = os.environ.get("CAROM_BIN")
    if given:
        return pathlib.Path(given)
    for profile in ("debug", "release"):
        path = ROOT / "target" / profile / "carom"
        if path.exists():
            return path
    return None


@pytest.fixture(scope="session")
def carom_bin():
    """The CLI built by `cargo build` / `cargo test` (or $CAROM_BIN)."""
    path = _find_binary()
    if path is None or not path.exists():
        pytest.fail(
            "no carom binary to compare with: run `cargo build` at the repository root "
            "(or set CAROM_BIN)"
        )
    return path


@pytest.fixture
def cli(carom_bin):
    """Runs `carom ARGS...`, returning the finished process; fails the test on a non-zero
    exit unless `check=False`."""

    def run(*args, check=True):
        done = subprocess.run(
            [str(carom_bin), *map(str, args)],
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
        )
        if check and done.returncode != 0:
            pytest.fail(f"carom {' '.join(map(str, args))} exited {done.returncode}: {done.stderr}")
        return done

    return run


def bits(array):
    """The float64 values' bit patterns (so that -0.0 and NaNs compare exactly)."""
    return np.ascontiguousarray(array, dtype=np.float64).view(np.uint64)


def assert_same_state(a, b):
    """Two worlds hold the very same bits."""
    assert a.steps == b.steps
    for name in ("positions", "velocities", "radii", "masses"):
        np.testing.assert_array_equal(bits(getattr(a, name)), bits(getattr(b, name)), err_msg=name)
