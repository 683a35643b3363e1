"""Shared fixtures: the `carom` binary to compare with, and helpers."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


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
