"""Threads and Ctrl-C: simulations release the GIL (Python keeps running beside them), and SIGINT
stops a long Test, Scene or Study run with KeyboardInterrupt within a couple of seconds, after
which the next run works (and a study goes on from the runs it kept)."""

from __future__ import annotations

import ctypes
import threading
import time

import numpy as np
import pytest

import demcal

from conftest import BOWL, interrupt_after, write_study

#: How long after SIGINT the KeyboardInterrupt must come (the native side polls every 100 ms,
#: a simulation looks at its stop flag every few hundred steps).
PROMPT_S = 2.0


def count_until(flag: list, since: float) -> tuple:
    """Counts in pure Python until `flag[0]` is set: (count, longest pause between two counts or
    since `since`, a perf_counter time)."""
    n, longest, last = 0, 0.0, since
    while not flag[0]:
        n += 1
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    return n, max(longest, time.perf_counter() - last)


@pytest.fixture(scope="module")
def counting_rate() -> float:
    """Counts per second of the loop with nothing else of this process running."""
    flag = [False]
    timer = threading.Timer(0.3, lambda: flag.__setitem__(0, True))
    t0 = time.perf_counter()
    timer.start()
    n, _ = count_until(flag, t0)
    return n / (time.perf_counter() - t0)


def count_while(work) -> tuple:
    """Runs `work` in another thread and counts in this one until it ends:
    (count, longest pause, seconds, work's result)."""
    out: dict = {}
    flag = [False]

    def run() -> None:
        try:
            out["result"] = work()
        finally:
            flag[0] = True

    t = threading.Thread(target=run)
    t0 = time.perf_counter()
    t.start()
    n, longest = count_until(flag, t0)
    seconds = time.perf_counter() - t0
    t.join()
    return n, longest, seconds, out.get("result")


# Were the GIL held for the whole run, the counting thread would stop for all of it (one pause
# as long as the run, a count near 0); with it released, the counting goes on beside the run
# (measured on 2 busy cores: at least half its pace). A pure-Python thread competing for the GIL
# leaves it about half. The longest pause allows for the machine's scheduler: with other
# processes on both cores, the counting thread itself waits for a core (0.25 s was seen).
SHARE = 0.2
PAUSE_S = 0.5


def check_counting(n: int, longest: float, seconds: float, rate: float) -> None:
    assert seconds > 2 * PAUSE_S  # long enough to tell (a held GIL pauses the counting for all of it)
    assert longest < PAUSE_S, (longest, seconds)
    assert n > SHARE * rate * seconds, (n, rate, seconds)


def test_the_measure_sees_a_call_that_keeps_the_gil(counting_rate):
    """The control: a C call made through ctypes.PyDLL keeps the GIL while it sleeps."""
    libc = ctypes.PyDLL(None)
    n, longest, seconds, _ = count_while(lambda: libc.usleep(1_200_000))
    assert seconds > 1.2 and longest > 1.0
    assert n < 0.05 * counting_rate * seconds


def test_the_gil_is_released_while_a_test_runs(tension, counting_rate):
    # Three runs in a row: one is under a second on a quiet machine, too short to tell.
    n, longest, seconds, rs = count_while(lambda: [tension.run(threads=1) for _ in range(3)])
    assert rs is not None and all(r.ok and r["peak_force_n"] > 0 for r in rs)
    check_counting(n, longest, seconds, counting_rate)


def test_the_gil_is_released_while_a_scene_runs(box_scene_file, counting_rate):
    scene = demcal.Scene.load(box_scene_file)
    n, longest, seconds, end = count_while(lambda: scene.simulate(steps=20000, threads=1))
    assert end is not None and end.steps == 20000
    check_counting(n, longest, seconds, counting_rate)


def test_the_gil_is_released_while_a_study_runs(tmp_path, counting_rate):
    slow = BOWL.replace("noise = 0.02", "noise = 0.02\nduration_s = 0.15")
    study = demcal.Study.load(write_study(tmp_path, slow))
    n, longest, seconds, out = count_while(lambda: study.run(jobs=2))
    assert "state: complete" in out
    check_counting(n, longest, seconds, counting_rate)


def test_two_tests_run_at_once_from_two_threads_give_the_numbers_of_one(tension):
    alone = tension.run(threads=1)
    results: list = [None, None]

    def run(i: int) -> None:
        results[i] = tension.run(threads=1)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results[0].responses == results[1].responses == alone.responses
    np.testing.assert_array_equal(results[0].curves["force_displacement"].y, alone.curves["force_displacement"].y)


def test_ctrl_c_stops_a_long_scene_run_and_the_next_run_works(box_scene_file):
    scene = demcal.Scene.load(box_scene_file)
    before = scene.simulate(steps=300, threads=2)
    # 200 000 steps of 891 spheres: about half a minute on 2 cores.
    with interrupt_after(1.0) as sig:
        with pytest.raises(KeyboardInterrupt):
            scene.simulate(steps=200_000, threads=2)
        stopped = time.perf_counter()
    assert sig.sent_at is not None and stopped - sig.sent_at < PROMPT_S
    after = scene.simulate(steps=300, threads=2)
    np.testing.assert_array_equal(after.position, before.position)


def test_ctrl_c_stops_a_long_test_run_and_the_next_run_works(quickstart, tension):
    before = tension.run(threads=2)
    # The quickstart cylinder lifted at 0.01 m/s instead of 0.1: over 20 s of wall time.
    with interrupt_after(1.5) as sig:
        t0 = time.perf_counter()
        with pytest.raises(KeyboardInterrupt):
            quickstart.run({"angle_of_repose.lift_speed": 0.01}, threads=2)
        stopped = time.perf_counter()
    assert sig.sent_at is not None and stopped - sig.sent_at < PROMPT_S and stopped - t0 < 1.5 + PROMPT_S
    assert tension.run(threads=2).responses == before.responses


def test_ctrl_c_stops_a_slow_formula():
    t = demcal.Test.from_dict({"test": "function", "function": {"expression": "1", "duration_s": 60.0}})
    with interrupt_after(0.5) as sig:
        with pytest.raises(KeyboardInterrupt):
            t.run()
        stopped = time.perf_counter()
    assert stopped - sig.sent_at < PROMPT_S
    assert demcal.Test.from_dict({"test": "function", "function": {"expression": "2"}}).run()["value"] == 2.0


def test_ctrl_c_keeps_a_studys_finished_runs_and_the_next_run_resumes(tmp_path, capfd):
    # Each run takes 0.2 s, 2 at a time: the 34 runs would take over 3 s.
    slow = BOWL.replace("noise = 0.02", "noise = 0.02\nduration_s = 0.2")
    study = demcal.Study.load(write_study(tmp_path, slow))
    with interrupt_after(1.5) as sig:
        with pytest.raises(KeyboardInterrupt):
            study.run(jobs=2)
        stopped = time.perf_counter()
    assert stopped - sig.sent_at < PROMPT_S
    kept = [r for r in study.results(frame=False) if r["status"] in ("done", "failed")]
    assert 4 <= len(kept) < 34
    assert "`demcal run" in study.status() and "state: complete" not in study.status()
    capfd.readouterr()
    out = study.run(jobs=2)
    err = capfd.readouterr().err
    assert "state: complete" in out
    rows = study.results(frame=False)
    assert len(rows) == 34
    # The runs kept are reused as they were (wall times included), not made again.
    by_key = {(r["stage"], r["run"]): r for r in rows}
    for r in kept:
        assert by_key[(r["stage"], r["run"])] == r
    # The first stage's stored runs are counted as such when the study goes on.
    first = [r for r in kept if r["stage"] == 1]
    if len(first) < 13:
        assert f"stage 1/5 screening: {13 - len(first)} runs to make ({len(first)} stored)" in err
    else:
        assert "stage 1/5 screening" not in err


# --- fork: rayon's threads stay in the parent ------------------------------------------------


def _in_a_forked_child(work, timeout_s: float = 60.0) -> tuple:
    """Runs `work()` in a child made by os.fork and returns (exit status, what it printed);
    a child still running after `timeout_s` is killed (the hang this guards against)."""
    import os
    import signal as sig

    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(r)
        try:
            out = repr(work())
            code = 0
        except BaseException as e:  # noqa: BLE001 - the parent reads what happened
            out = f"{type(e).__name__}: {e}"
            code = 1
        os.write(w, out.encode())
        os._exit(code)
    os.close(w)
    deadline = time.monotonic() + timeout_s
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, sig.SIGKILL)
            os.waitpid(pid, 0)
            os.close(r)
            pytest.fail(f"the forked child did not finish in {timeout_s} s")
        time.sleep(0.05)
    with os.fdopen(r) as f:
        text = f.read()
    return os.waitstatus_to_exitcode(status), text


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="no fork on this platform")
def test_a_run_in_a_forked_child_finishes_with_the_parents_numbers(tension, tmp_path):
    """With rayon's global pool used in the parent, a child's run once waited forever."""
    parent = tension.run()  # uses the global pool here
    code, text = _in_a_forked_child(lambda: tension.run()["peak_force_n"])
    assert code == 0, text
    assert float(text) == parent["peak_force_n"]
    study = demcal.Study.load(write_study(tmp_path))
    code, text = _in_a_forked_child(lambda: study.run(jobs=1))
    assert code == 1 and text.startswith("InputError: ") and "spawn" in text, text
