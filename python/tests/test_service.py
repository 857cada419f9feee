"""Python planners on the benchmark service over real gRPC: a grpcio planner server validated by the worker, an
``exec`` planner script, a whole submission through ``vb serve``, and the ``Sim`` API that ``vb serve`` serves."""

import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import vertibench as vb
from vertibench.baselines import PID
from vertibench.serve import serve

ROOT = Path(__file__).resolve().parents[2]
PURE_PURSUIT = ROOT / "examples" / "python" / "pure_pursuit.py"


def binary(var):
    path = os.environ.get(var)
    if not path:
        pytest.skip(f"SKIPPED: {var} is not set (.ci/run sets it to the binary `cargo test` built)")
    return path


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_grpcio_planner_server_passes_the_workers_validation():
    """grpcio sends response headers only with the first answer: the worker must send EpisodeStart first."""
    vb_submit = binary("VB_SUBMIT_BIN")
    addr = f"127.0.0.1:{free_port()}"
    server = serve(PID(), addr, block=False)
    try:
        r = subprocess.run(
            [vb_submit, "validate", "endpoint", f"http://{addr}", "--task", "w001-t0", "--max-time", "8",
             "--task-dir", vb.default_task_set()],
            capture_output=True, text=True, timeout=120,
        )
    finally:
        server.stop(None)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "OK: the planner follows the protocol" in r.stdout


def test_vb_submit_validates_a_python_planner_script():
    vb_submit = binary("VB_SUBMIT_BIN")
    r = subprocess.run(
        [vb_submit, "validate", "exec", "--task", "w002-t1", "--max-time", "8", "--task-dir", vb.default_task_set(),
         "--", sys.executable, str(PURE_PURSUIT)],
        capture_output=True, text=True, timeout=120,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert "OK: the planner follows the protocol" in r.stdout


class Raises(vb.Planner):
    name = "raises"

    def act(self, obs):
        raise RuntimeError("no plan")


def test_a_planner_that_raises_fails_validation_with_its_traceback():
    vb_submit = binary("VB_SUBMIT_BIN")
    addr = f"127.0.0.1:{free_port()}"
    server = serve(Raises(), addr, block=False)
    try:
        r = subprocess.run(
            [vb_submit, "validate", "endpoint", f"http://{addr}", "--task-dir", vb.default_task_set()],
            capture_output=True, text=True, timeout=120,
        )
    finally:
        server.stop(None)
    assert r.returncode != 0
    assert "planner_crash" in r.stdout + r.stderr and "RuntimeError: no plan" in r.stdout + r.stderr


@pytest.fixture
def service(tmp_path):
    """`vb serve` on free ports with a fresh store; yields (coordinator URL, token)."""
    vb_bin = binary("VB_BIN")
    grpc, http = free_port(), free_port()
    log = open(tmp_path / "serve.log", "w+")
    proc = subprocess.Popen(
        [vb_bin, "serve", "--db", f"sqlite://{tmp_path}/vb.db", "--grpc", f"127.0.0.1:{grpc}", "--http",
         f"127.0.0.1:{http}", "--slots", "2", "--task-dir", vb.default_task_set()],
        stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path,
    )
    try:
        token = None
        for _ in range(300):
            log.seek(0)
            m = re.search(r"VB_TOKEN=(\S+)", log.read())
            if m:
                token = m.group(1)
                break
            assert proc.poll() is None, "vb serve exited"
            time.sleep(0.1)
        assert token, "vb serve printed no token"
        yield f"http://127.0.0.1:{grpc}", token
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_a_python_planner_through_the_service_gives_the_in_process_results(service, tmp_path):
    url, token = service
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    tasks = "w001-t0,w001-t1,w040-t2"
    r = subprocess.run(
        [binary("VB_SUBMIT_BIN"), "exec", "--tasks", tasks, "--wait", "--name", "pure-pursuit", "--",
         sys.executable, str(PURE_PURSUIT)],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    sid = re.search(r"submitted (\S+)", r.stdout).group(1)
    r = subprocess.run([binary("VB_SUBMIT_BIN"), "results", sid, "--format", "csv"], capture_output=True,
                       text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr
    import io

    import pandas as pd

    service_rows = pd.read_csv(io.StringIO(r.stdout)).set_index("task_id").sort_index()
    sys.path.insert(0, str(PURE_PURSUIT.parent))
    from pure_pursuit import PurePursuit

    local, _ = vb.evaluate(PurePursuit(), tasks, out=tmp_path / "local", progress=False)
    local = local.set_index("task_id").sort_index()
    assert list(service_rows.index) == list(local.index)
    assert list(service_rows.outcome) == list(local.outcome)


def test_vb_serve_serves_the_sim_api(service):
    import grpc

    from vertibench import protocol as pb

    url, _ = service
    channel = grpc.insecure_channel(url.removeprefix("http://"))

    def call(method, request, response):
        rpc = channel.unary_unary(f"/{pb.SIM_SERVICE}/{method}", request_serializer=request.__class__.SerializeToString,
                                  response_deserializer=response.FromString)
        return rpc(request, timeout=60)

    created = call("CreateEpisode", pb.CreateEpisodeRequest(task_id="w001-t0", control_dt=0.1), pb.CreateEpisodeResponse)
    assert created.vehicle.name == "hmmwv"
    r = call("Reset", pb.ResetRequest(episode_id=created.episode_id), pb.StepResponse)
    assert r.observation.state.time == 0.0
    for _ in range(20):
        r = call("Step", pb.StepRequest(episode_id=created.episode_id, action=pb.Action(throttle=0.6)), pb.StepResponse)
    assert r.observation.state.time == pytest.approx(2.0, abs=0.05)
    assert r.reward.progress > 0 and r.reward.roll_penalty <= 0
    call("CloseEpisode", pb.CloseEpisodeRequest(episode_id=created.episode_id), pb.CloseEpisodeResponse)


def test_vb_worker_serves_the_sim_api_on_its_own_address():
    import grpc

    from vertibench import protocol as pb

    port = free_port()
    # No coordinator is needed for the Sim API: the worker keeps retrying to register meanwhile.
    proc = subprocess.Popen([binary("VB_BIN"), "worker", "--coordinator", f"http://127.0.0.1:{free_port()}", "--sim",
                             f"127.0.0.1:{port}", "--task-dir", vb.default_task_set()],
                            env={**os.environ, "VB_WORKER_TOKEN": "unused"}, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        channel = grpc.insecure_channel(f"127.0.0.1:{port}")
        grpc.channel_ready_future(channel).result(timeout=60)
        rpc = channel.unary_unary(f"/{pb.SIM_SERVICE}/CreateEpisode",
                                  request_serializer=pb.CreateEpisodeRequest.SerializeToString,
                                  response_deserializer=pb.CreateEpisodeResponse.FromString)
        created = rpc(pb.CreateEpisodeRequest(task_id="w003-t2"), timeout=30)
        assert created.task.task_id == "w003-t2" and created.episode_id
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_wait_fails_when_the_planner_never_worked(service, tmp_path):
    url, token = service
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    broken = tmp_path / "broken.py"
    broken.write_text("raise SystemExit('this planner cannot start')\n")
    r = subprocess.run(
        [binary("VB_SUBMIT_BIN"), "exec", "--tasks", "w001-t0,w001-t1", "--wait", "--", sys.executable, str(broken)],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert r.returncode != 0, r.stdout + r.stderr
    assert "2 of 2 finished episodes failed because of the planner or the infrastructure" in r.stderr, r.stderr


MAPPING_PLANNER = """
import sys
from vertibench.baselines import PID
from vertibench.serve import serve


class Mapping(PID):
    # PID that reports what it knows of the map it was given at reset (updated in place by serve()).
    def reset(self, task, vehicle, maps):
        super().reset(task, vehicle, maps)
        self.maps, self.steps = maps, 0

    def act(self, obs):
        self.steps += 1
        if self.steps % 100 == 0:
            known = self.maps.known
            print(f"believed={self.maps.believed} known={int(known.sum())} cells={known.size}", file=sys.stderr,
                  flush=True)
        return super().act(obs)


serve(Mapping())
"""


def test_a_python_planner_under_nominal_perception_keeps_the_map_the_sensor_builds(service, tmp_path):
    """`vb-submit --perception nominal`: the planner's Maps start unknown and fill in as the vehicle drives
    (serve() pastes each observation's MapUpdate into them), never all known."""
    url, token = service
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    script = tmp_path / "mapping.py"
    script.write_text(MAPPING_PLANNER)
    r = subprocess.run(
        [binary("VB_SUBMIT_BIN"), "exec", "--tasks", "w001-t0", "--perception", "nominal", "--wait", "--",
         sys.executable, str(script)],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    sid = re.search(r"submitted (\S+)", r.stdout).group(1)
    log = subprocess.run([binary("VB_SUBMIT_BIN"), "log", sid, "w001-t0"], capture_output=True, text=True,
                         timeout=60, env=env)
    assert log.returncode == 0, log.stderr
    reports = [tuple(int(v) for v in m.groups()) for m in
               re.finditer(r"believed=True known=(\d+) cells=(\d+)", log.stdout)]
    assert len(reports) >= 2, log.stdout
    assert 0 < reports[0][0] < reports[-1][0] < reports[-1][1], reports
    results = subprocess.run([binary("VB_SUBMIT_BIN"), "results", sid, "--format", "json"], capture_output=True,
                             text=True, timeout=60, env=env)
    import json

    assert json.loads(results.stdout)["perception"].startswith("nominal@")
