"""``vertibench.evaluate`` as researchers drive it: Ctrl-C keeps what finished, a resume says so and refuses another
planner, a planner past its deadline fails its episode, bad arguments are named, and it works after ``os.fork()``.

The interrupt and fork tests run ``evaluate`` in a subprocess; their timeouts only catch a hang (a test that hangs
fails instead of hanging pytest), they assert no speed."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pandas as pd
import pytest

import vertibench as vb
from vertibench.baselines import PID

# Catches a hang; never a speed assertion.
HANG = 60


def results_lines(out):
    p = out / "results.jsonl"
    return len(p.read_text().splitlines()) if p.exists() else 0


def start(script: str, tmp_path, *args, env=None):
    path = tmp_path / "script.py"
    path.write_text(textwrap.dedent(script))
    return subprocess.Popen([sys.executable, str(path), *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=dict(os.environ, **(env or {})))


def interrupt_once_running(proc, out, rows=1):
    """SIGINT to ``proc`` once ``out`` holds ``rows`` finished episodes; its (stdout, stderr) once it ends."""
    deadline = time.monotonic() + HANG
    while results_lines(out) < rows:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no episode finished"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    try:
        stdout, stderr = proc.communicate(timeout=HANG)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("evaluate did not stop on SIGINT")
    assert proc.returncode == 0, stderr
    return stdout, stderr


RUN = """
    import os, signal, sys, time
    import vertibench as vb
    from vertibench.baselines import PID

    # Python leaves SIGINT ignored when it starts so (a background job of a shell): Ctrl-C as in a terminal.
    signal.signal(signal.SIGINT, signal.default_int_handler)

    class Slow(PID):
        # The PID, slow after its first episode when VB_TEST_DELAY says so.

        name = "slow"
        _episodes = 0

        def reset(self, task, vehicle, maps):
            self._episodes += 1
            super().reset(task, vehicle, maps)

        def act(self, obs):
            if self._episodes > 1:
                time.sleep(float(os.environ.get("VB_TEST_DELAY", "0")))
            return super().act(obs)

    planner = Slow() if sys.argv[1] == "slow" else sys.argv[1]
    df, summary = vb.evaluate(planner, sys.argv[2], out=sys.argv[3], progress=False)
    print("returned", len(df), summary["complete"], flush=True)
"""


def check_kept(out, stdout, stderr):
    """What an interrupted evaluation returned is what it kept in ``out`` and wrote to its report."""
    n = int(stdout.split()[1])
    assert stdout.split()[2] == "False", stdout
    assert "interrupted" in stderr and f"{n} of" in stderr and "same out=" in stderr, stderr
    assert results_lines(out) == n
    assert len(pd.read_csv(out / "episodes.csv")) == n
    assert (out / "summary.json").is_file()
    return n


def test_ctrl_c_stops_a_built_in_evaluation_and_keeps_what_finished(tmp_path):
    out = tmp_path / "pid"
    proc = start(RUN, tmp_path, "pid", "all", out)
    stdout, stderr = interrupt_once_running(proc, out, rows=4)
    n = check_kept(out, stdout, stderr)
    assert n < 1000
    # Resuming on the finished tasks and one more runs only that one.
    done = list(pd.read_csv(out / "episodes.csv").task_id)
    more = next(f"w{w:03d}-t{t}" for w in range(1, 101) for t in range(10) if f"w{w:03d}-t{t}" not in done)
    r = subprocess.run([sys.executable, str(tmp_path / "script.py"), "pid", ",".join(done + [more]), str(out)],
                       capture_output=True, text=True, timeout=HANG)
    assert r.returncode == 0, r.stderr
    assert f"resuming in {out}: keeping the {n} of {n + 1} episodes" in r.stderr, r.stderr
    assert r.stdout.split()[1:] == [str(n + 1), "True"]
    assert results_lines(out) == n + 1


def test_ctrl_c_stops_a_python_planner_in_its_act_and_a_rerun_resumes(tmp_path):
    out = tmp_path / "slow"
    tasks = "w001-t0,w001-t1,w001-t2,w002-t0"
    # The first episode at full speed, then slowly: the signal lands in `act`, most likely in its sleep.
    proc = start(RUN, tmp_path, "slow", tasks, out, env={"VB_TEST_DELAY": "0.02"})
    stdout, stderr = interrupt_once_running(proc, out)
    n = check_kept(out, stdout, stderr)
    assert n < 4
    r = subprocess.run([sys.executable, str(tmp_path / "script.py"), "slow", tasks, str(out)], capture_output=True,
                       text=True, timeout=HANG)
    assert r.returncode == 0, r.stderr
    assert f"keeping the {n} of 4 episodes" in r.stderr, r.stderr
    assert r.stdout.split()[1:] == ["4", "True"]


STUCK = """
    import signal, sys, time
    import vertibench as vb

    signal.signal(signal.SIGINT, signal.default_int_handler)

    class Stuck(vb.Planner):
        # act never returns: it loops on short sleeps until stopped.
        name = "stuck"

        def act(self, obs):
            while True:
                time.sleep(0.01)

    tasks = ",".join(f"w001-t{t}" for t in range(10)) + "," + ",".join(f"w002-t{t}" for t in range(10))
    df, summary = vb.evaluate(Stuck(), tasks, out=sys.argv[1], progress=False, step_timeout=1.0)
    print("returned", len(df), summary["complete"], flush=True)
"""


def test_ctrl_c_stops_an_evaluation_whose_planner_is_stuck_in_act(tmp_path):
    """Issue 58, point 5: SIGINT while ``act`` loops on ``time.sleep(0.01)`` (each episode ending
    ``planner_timeout`` after 1 s) stops the evaluation, keeping the finished episodes; it went on for as long as
    it was watched. The bound only tells a stop from a run that goes on."""
    out = tmp_path / "stuck"
    path = tmp_path / "stuck.py"
    path.write_text(textwrap.dedent(STUCK))
    proc = subprocess.Popen([sys.executable, str(path), str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + HANG
    while results_lines(out) < 2:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no episode finished"
        time.sleep(0.05)
    time.sleep(0.3)  # inside the third episode's act
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    try:
        stdout, stderr = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
        pytest.fail(f"evaluate went on after SIGINT ({results_lines(out)} episodes): {stderr[-2000:]}")
    assert proc.returncode == 0, stderr
    n = check_kept(out, stdout, stderr)
    assert 2 <= n < 20, (n, time.monotonic() - t0)


def test_a_background_job_that_ignores_sigint_is_told_so_and_stops_on_sigterm(tmp_path):
    """Issue 58, point 5, as it was found: started as a background job of a non-interactive shell, a process has
    SIGINT ignored and Python keeps it so, so ``kill -INT`` could not stop the evaluation (nor any Python program).
    ``evaluate`` now says so on stderr at once, and SIGTERM stops it as Ctrl-C does, keeping what finished."""
    out = tmp_path / "bg"
    path = tmp_path / "stuck.py"
    path.write_text(textwrap.dedent(STUCK).replace("signal.signal(signal.SIGINT, signal.default_int_handler)", ""))
    proc = subprocess.Popen([sys.executable, str(path), str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + HANG
    while results_lines(out) < 2:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no episode finished"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)  # ignored, as the process asked
    time.sleep(0.5)
    assert proc.poll() is None
    proc.send_signal(signal.SIGTERM)
    try:
        stdout, stderr = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("evaluate went on after SIGTERM")
    assert proc.returncode == 0, stderr
    assert "SIGINT is ignored in this process" in stderr and "send SIGTERM" in stderr, stderr
    n = check_kept(out, stdout, stderr)
    assert 2 <= n < 20


class Forever(vb.Planner):
    name = "forever"

    def act(self, obs):
        if obs.time >= 0.5:
            while True:
                pass
        return (0.0, 0.5, 0.0)


class Sleeps(vb.Planner):
    name = "sleeps"

    def reset(self, task, vehicle, maps):
        self._slept = False

    def act(self, obs):
        if obs.time >= 0.5 and not self._slept:
            self._slept = True
            time.sleep(0.4)  # native code: not stopped, failed once it returns
        return (0.0, 0.5, 0.0)


def test_a_planner_past_its_step_timeout_fails_its_episode_and_the_evaluation_goes_on(tmp_path):
    df, summary = vb.evaluate(Forever(), "w001-t0,w001-t1", out=tmp_path / "f", progress=False, step_timeout=0.2)
    assert list(df.reason) == ["planner_timeout"] * 2 and summary["complete"]
    assert re.search(r"act at t = 0\.5\d s was stopped after \d+\.\d\d s, past its deadline step_timeout=0\.2 s",
                     df.detail[0]), df.detail[0]
    df, _ = vb.evaluate(Sleeps(), "w001-t0", out=tmp_path / "s", progress=False, step_timeout=0.2)
    # Stopped as soon as the sleep returns to Python code.
    assert df.reason[0] == "planner_timeout" and re.search(r"(took|stopped after) 0\.4", df.detail[0]), df.detail[0]
    # No deadline: the same sleeps are only slow.
    df, _ = vb.evaluate(Sleeps(), "w001-t0", out=tmp_path / "n", progress=False, step_timeout=None)
    assert df.reason[0] != "planner_timeout"


def test_the_planner_runs_in_the_calling_thread(tmp_path):
    threads = set()

    class Where(PID):
        def act(self, obs):
            threads.add(threading.get_ident())
            return super().act(obs)

    vb.evaluate(Where(), "w001-t0", out=tmp_path / "w", progress=False)
    assert threads == {threading.get_ident()}


class Gain(PID):
    def __init__(self, gain=1.0):
        self.gain = gain


def test_a_changed_planner_is_refused_naming_out(tmp_path):
    out = tmp_path / "r"
    vb.evaluate(Gain(1.0), "w001-t0", out=out, progress=False)
    # State set while running is no parameter: the same planner resumes.
    vb.evaluate(Gain(1.0), "w001-t0,w001-t1", out=out, progress=False)
    with pytest.raises(ValueError, match=r"gain 1\.0 -> 2\.0.*use another out=") as e:
        vb.evaluate(Gain(2.0), "w001-t0,w001-t1", out=out, progress=False)
    assert "--out" not in str(e.value)
    # Another class under the same name.
    vb.evaluate(PID(), "w001-t0", out=tmp_path / "p", progress=False)
    copy = type("Copy", (PID,), {})
    with pytest.raises(ValueError, match=r"class vertibench\.baselines\.PID .*, not .*class test_evaluate_control\.Copy"):
        vb.evaluate(copy(), "w001-t0", out=tmp_path / "p", progress=False)
    # An explicit version stands for the parameters.
    v1 = type("Versioned", (Gain,), {"version": "1"})
    vb.evaluate(v1(1.0), "w001-t0", out=tmp_path / "v", progress=False)
    vb.evaluate(v1(3.0), "w001-t0", out=tmp_path / "v", progress=False)
    with pytest.raises(ValueError, match="version 1, not .*version 2"):
        vb.evaluate(type("Versioned", (Gain,), {"version": 2})(), "w001-t0", out=tmp_path / "v", progress=False)


def test_bad_arguments_are_named():
    with pytest.raises(TypeError, match="planner must be a vertibench.Planner"):
        vb.evaluate(object(), "w001-t0")
    with pytest.raises(TypeError, match=r"pass PID\(\)"):
        vb.evaluate(PID, "w001-t0")
    for kwargs, name in [({"scale": -1.0}, "scale"), ({"step_timeout": 0}, "step_timeout"),
                         ({"num_threads": 0}, "num_threads"), ({"rules": "fast"}, "rules")]:
        with pytest.raises(ValueError, match=name):
            vb.evaluate("pid", "w001-t0", **kwargs)
    bad = PID()
    bad.control_rate_hz = -5
    with pytest.raises(ValueError, match="planner.control_rate_hz"):
        vb.evaluate(bad, "w001-t0")
    with pytest.raises(ValueError, match="unknown planner `teleport`"):
        vb.evaluate("teleport", "w001-t0")


FORK = """
    import os, sys
    import vertibench as vb
    from vertibench.baselines import PID

    vb.evaluate("pid", "w001-t0,w001-t1", out=sys.argv[1] + "/parent", progress=False)
    pid = os.fork()
    if pid == 0:
        a, _ = vb.evaluate("pid", "w001-t0,w001-t1", out=sys.argv[1] + "/child", progress=False)
        b, _ = vb.evaluate(PID(), "w001-t0", out=sys.argv[1] + "/child-python", progress=False)
        os._exit(0 if (len(a), len(b)) == (2, 1) else 1)
    _, status = os.waitpid(pid, 0)
    sys.exit(os.waitstatus_to_exitcode(status))
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="SKIPPED: no os.fork on this platform")
def test_an_evaluation_runs_in_a_forked_child(tmp_path):
    proc = start(FORK, tmp_path, tmp_path)
    try:
        _, stderr = proc.communicate(timeout=HANG)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("the forked child's evaluation hung")
    assert proc.returncode == 0, stderr
