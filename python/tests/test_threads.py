"""`World.step` releases the GIL, and Ctrl-C stops it between two steps.

No timings: a world is busy (its lock held) exactly while `step` runs, and a thread that can
observe that it is busy is one that ran Python code during the step, which it could not do if
the step held the GIL.
"""

import _thread
import os
import signal
import threading

import pytest

import carom
from conftest import assert_same_state


def is_busy(world):
    try:
        world.steps
    except RuntimeError as e:
        assert "busy" in str(e)
        return True
    return False


def test_another_thread_runs_python_while_step_runs():
    world = carom.preset("lecture_5000_grid100")
    progress = {"busy_reads": 0, "python_work": 0}
    finished = threading.Event()

    def watch():
        # runs Python until the step is over; counts what it did while the world was busy
        while not finished.is_set():
            if is_busy(world):
                progress["busy_reads"] += 1
                progress["python_work"] += sum(range(1000)) > 0
            else:
                threading.Event().wait(0.001)

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        world.step(300)
    finally:
        finished.set()
        watcher.join()
    assert world.steps == 300
    assert progress["busy_reads"] > 0 and progress["python_work"] > 0
    twin = carom.preset("lecture_5000_grid100")
    twin.step(300)
    assert_same_state(world, twin)


def test_step_in_a_thread_leaves_the_caller_free():
    world = carom.preset("lecture_5000_grid100")
    seen_busy = []
    stepper = threading.Thread(target=world.step, args=(300,))
    stepper.start()
    while stepper.is_alive():
        if is_busy(world):
            seen_busy.append(True)
        else:
            threading.Event().wait(0.001)
    stepper.join()
    assert seen_busy
    assert world.steps == 300
    assert "300" in repr(world)


def interrupt_when_busy(world, how):
    while not is_busy(world):
        threading.Event().wait(0.001)
    if how == "interrupt_main":
        _thread.interrupt_main()
    else:
        os.kill(os.getpid(), signal.SIGINT)


@pytest.mark.parametrize("how", ["interrupt_main", "sigint"])
def test_ctrl_c_stops_between_two_steps(how):
    assert threading.current_thread() is threading.main_thread()
    world = carom.preset("lecture_100_k05")
    world.step(3)
    far = 10**12 - 3  # (the most steps a world may take from step 3)
    # Python's own Ctrl-C handler, even where the process started with SIGINT ignored (a
    # background job of a shell without job control)
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    helper = threading.Thread(target=interrupt_when_busy, args=(world, how))
    helper.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            world.step(far)
    finally:
        helper.join()
        signal.signal(signal.SIGINT, old)
    steps = world.steps
    assert type(steps) is int and 3 < steps < far
    # the state is that of a whole step: a fresh world stepped as far holds the same bits
    fresh = carom.preset("lecture_100_k05")
    fresh.step(steps)
    assert_same_state(world, fresh)
    # and it steps on as if nothing had happened
    world.step(7)
    fresh.step(7)
    assert_same_state(world, fresh)


def test_a_signal_handler_exception_stops_the_step_too():
    world = carom.preset("lecture_100_k05")

    class Stop(Exception):
        pass

    def handler(signum, frame):
        raise Stop("stop")

    old = signal.signal(signal.SIGUSR1, handler)
    helper = threading.Thread(
        target=lambda: (
            [threading.Event().wait(0.001) for _ in iter(lambda: is_busy(world), True)],
            os.kill(os.getpid(), signal.SIGUSR1),
        )
    )
    try:
        helper.start()
        with pytest.raises(Stop):
            world.step(10**12)
    finally:
        helper.join()
        signal.signal(signal.SIGUSR1, old)
    fresh = carom.preset("lecture_100_k05")
    fresh.step(world.steps)
    assert_same_state(world, fresh)
