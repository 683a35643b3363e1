"""Every error: one clear message naming the problem, the right exception, nothing written."""

import os
import struct

import numpy as np
import pytest

import carom
from conftest import SCENES, assert_same_state

BAD_FIELD = """
dimensions = 2
dt = 0.01
[[particles]]
position = [0.0, 0.0]
velocity = [0.0, 0.0]
radius = -1.0
mass = 1.0
"""


def test_scene_error_is_a_value_error():
    assert issubclass(carom.SceneError, ValueError)


def test_bad_field_gives_the_cli_message(cli, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(BAD_FIELD)
    with pytest.raises(carom.SceneError) as caught:
        carom.load(path)
    done = cli("run", path, check=False)
    assert done.returncode == 2
    assert done.stderr.strip() == f"carom: error: {caught.value}"
    assert str(path) in str(caught.value) and "particles[0].radius" in str(caught.value)
    assert caught.value.origin == str(path)
    assert caught.value.field == "particles[0].radius"


def test_broken_toml_gives_the_cli_message(cli, tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("dimensions = 2\ndt = [\n")
    with pytest.raises(carom.SceneError) as caught:
        carom.load(path)
    done = cli("run", path, check=False)
    assert done.stderr.strip() == f"carom: error: {caught.value}"
    assert caught.value.field is None


@pytest.mark.parametrize(
    "text,field",
    [
        ("dimensions = 4\ndt = 0.1", "dimensions"),
        ("dimensions = 2\ndt = 0.0", "dt"),
        ("dimensions = 2\ndt = 0.1\nrestitution = 2.0", "restitution"),
        ("dimensions = 3\ndt = 0.1\ngravity = [0.0, -9.8]", "gravity"),
    ],
)
def test_from_toml_names_the_field(text, field):
    with pytest.raises(carom.SceneError) as caught:
        carom.from_toml(text)
    assert str(caught.value).startswith(f"<string>: field `{field}`: ")
    assert caught.value.field == field and caught.value.origin == "<string>"


def test_unknown_preset():
    with pytest.raises(ValueError, match="no built-in scene `nope`; there are: lecture_100_k05"):
        carom.preset("nope")


def test_missing_scene_file(tmp_path):
    with pytest.raises(FileNotFoundError) as caught:
        carom.load(tmp_path / "missing.toml")
    assert "cannot read scene file" in str(caught.value)
    assert caught.value.filename == str(tmp_path / "missing.toml")


@pytest.fixture
def world():
    w = carom.preset("lecture_100_k05")
    w.step(5)
    return w


@pytest.mark.parametrize(
    "value,message",
    [
        (np.zeros((100, 3)), r"needs shape \(100, 2\) .*got \(100, 3\)"),
        (np.zeros((99, 2)), r"needs shape \(100, 2\) .*got \(99, 2\)"),
        (np.zeros(200), r"needs shape \(100, 2\) .*got \(200,\)"),
        (np.zeros((100, 2, 1)), r"needs shape \(100, 2\) .*got \(100, 2, 1\)"),
        (5.0, r"needs shape \(100, 2\) .*got \(\)"),
        ([["a", "b"]] * 100, r"must be real numbers .* numpy kind 'U'"),
    ],
)
def test_set_velocities_refuses_wrong_shapes(world, value, message):
    before = world.velocities
    with pytest.raises(ValueError, match="^velocities: " + message):
        world.set_velocities(value)
    np.testing.assert_array_equal(world.velocities, before)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_set_velocities_refuses_non_finite_values(world, bad):
    before = world.velocities
    v = before.copy()
    v[42, 1] = bad
    with pytest.raises(ValueError, match=r"^velocities: must be finite; row 42 \(particle 42\)"):
        world.set_velocities(v)
    np.testing.assert_array_equal(world.velocities, before)


def test_step_refuses_negative_counts(world):
    with pytest.raises(ValueError, match="n: the number of steps must be >= 0, got -1"):
        world.step(-1)
    with pytest.raises(TypeError):
        world.step(1.5)
    assert world.steps == 5


def only(path):
    return sorted(p.name for p in path.iterdir())


def test_writes_into_a_missing_folder(world, tmp_path):
    for write in (world.write_csv, world.checkpoint):
        with pytest.raises(FileNotFoundError, match="folder .* does not exist"):
            write(tmp_path / "missing" / "out")
    assert only(tmp_path) == []


def test_writes_over_a_folder(world, tmp_path):
    (tmp_path / "dir").mkdir()
    for write in (world.write_csv, world.checkpoint):
        with pytest.raises(IsADirectoryError, match="is a folder"):
            write(tmp_path / "dir")
    assert only(tmp_path) == ["dir"] and only(tmp_path / "dir") == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_writes_into_a_read_only_folder(world, tmp_path):
    os.chmod(tmp_path, 0o500)
    try:
        with pytest.raises(PermissionError):
            world.write_csv(tmp_path / "out.csv")
    finally:
        os.chmod(tmp_path, 0o700)


def test_resume_of_a_missing_checkpoint(tmp_path):
    with pytest.raises(FileNotFoundError, match="cannot read checkpoint"):
        carom.resume(tmp_path / "missing.ckpt")


def test_resume_of_a_foreign_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(BAD_FIELD)
    with pytest.raises(ValueError, match=f"^{path}: ") as caught:
        carom.resume(path)
    assert not isinstance(caught.value, carom.SceneError)


def test_resume_of_a_damaged_checkpoint(world, tmp_path, cli):
    path = tmp_path / "run.ckpt"
    world.checkpoint(path)
    data = bytearray(path.read_bytes())
    for damaged in (data[: len(data) // 2], data[:-1] + bytes([data[-1] ^ 1])):
        path.write_bytes(bytes(damaged))
        with pytest.raises(ValueError) as caught:
            carom.resume(path)
        done = cli("resume", path, check=False)
        assert done.returncode == 2
        assert done.stderr.strip() == f"carom: error: {caught.value}"


def test_writes_over_a_named_pipe(world, tmp_path):
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    for write in (world.write_csv, world.checkpoint):
        with pytest.raises(OSError, match="not a regular file"):
            write(pipe)
    assert only(tmp_path) == ["pipe"] and not pipe.is_file()


def test_step_refuses_a_bool_and_counts_past_the_limit(world):
    with pytest.raises(TypeError, match="bool"):
        world.step(True)
    with pytest.raises(ValueError, match="past the limit of 1000000000000 steps"):
        world.step(10**12)
    assert world.steps == 5


def test_step_refuses_a_thread_count_carom_refuses(world, monkeypatch):
    monkeypatch.setenv("RAYON_NUM_THREADS", "100000")
    with pytest.raises(ValueError, match="RAYON_NUM_THREADS: 100000 is more than the limit"):
        world.step(1)
    assert world.steps == 5


@pytest.mark.parametrize(
    "value,message",
    [
        (1 + 5j, "numpy kind 'c'"),
        (np.datetime64("2020-01-01", "D"), "numpy kind 'M'"),
        (True, "numpy kind 'b'"),
        ("7", "numpy kind 'U'"),
        (1e16, "beyond carom's range"),
    ],
)
def test_set_velocities_refuses_what_is_not_a_velocity(world, value, message):
    before = world.velocities
    with pytest.raises(ValueError, match=message):
        world.set_velocities(np.full((len(world), 2), value))
    assert np.array_equal(world.velocities, before)


def test_writes_over_the_scene_file(tmp_path):
    scene = tmp_path / "scene.toml"
    text = (SCENES / "lecture_100_k05.toml").read_text()
    scene.write_text(text)
    world = carom.load(scene)
    for write in (world.write_csv, world.checkpoint):
        with pytest.raises(ValueError, match="the scene file this world was read from"):
            write(scene)
    assert scene.read_text() == text


def test_load_and_resume_of_a_named_pipe(tmp_path):
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    for read in (carom.load, carom.resume):
        with pytest.raises(OSError, match="not a regular file"):
            read(pipe)


def with_checksum(body):
    """A checkpoint's bytes: `body` and its FNV-1a hash (see carom_output::checkpoint)."""
    h = 0xCBF29CE484222325
    for byte in body:
        h = ((h ^ byte) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return bytes(body) + struct.pack("<Q", h)


def test_resume_of_a_checkpoint_whose_values_no_scene_may_give(world, tmp_path, cli):
    """The checksum holds, the values do not: refused as `carom resume` refuses them."""
    path = tmp_path / "run.ckpt"
    world.checkpoint(path)
    body = bytearray(path.read_bytes()[:-8])
    at = 8 + 4 + 4
    (steps, n) = struct.unpack_from("<QQ", body, at)
    at += 16
    for _ in range(3):  # scene text, origin, run settings
        (length,) = struct.unpack_from("<Q", body, at)
        at += 8 + length
    at += 4 * n  # storage order
    velocities = at + 8 * 2 * n
    for offset, value, says in [
        (velocities, 1e300, "particle 0: velocity"),
        (16, 1 << 62, "past the limit"),
    ]:
        damaged = bytearray(body)
        if offset == 16:
            struct.pack_into("<Q", damaged, offset, value)
        else:
            struct.pack_into("<d", damaged, offset, value)
        path.write_bytes(with_checksum(damaged))
        with pytest.raises(ValueError, match=says) as caught:
            carom.resume(path)
        done = cli("resume", path, check=False)
        assert done.returncode == 2
        assert done.stderr.strip() == f"carom: error: {caught.value}"


def test_busy_world_and_unusable_calls_do_not_change_state(world):
    twin = carom.preset("lecture_100_k05")
    twin.step(5)
    for bad in (lambda: world.step(-3), lambda: world.set_velocities(np.zeros(3))):
        with pytest.raises(ValueError):
            bad()
    assert_same_state(world, twin)


THREADS_THAT_CANNOT_START = """
import carom
for attempt in range(2):
    try:
        carom.preset("lecture_100_k05")
    except RuntimeError as e:
        print("RuntimeError:", e)
"""


def test_threads_that_cannot_start_raise_runtime_error_not_a_panic():
    # (no room for the worker threads' stacks, which RUST_MIN_STACK sizes: as a low
    # `ulimit -u`, the pool cannot start; rayon tries once a process, so both attempts fail)
    import subprocess
    import sys

    env = dict(os.environ, RUST_MIN_STACK="1000000000000000")
    done = subprocess.run(
        [sys.executable, "-c", THREADS_THAT_CANNOT_START],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 2, done.stdout
    assert all("cannot start the worker threads" in line for line in lines), lines
    assert "panicked" not in done.stderr, done.stderr
