"""A Python planner in a container image built from scratch (deploy/build-python-planner-image.sh), submitted as an
`image` planner to `vb serve`: it gives the in-process results. Skipped, and said so, where Docker is absent."""

import os
import re
import shutil
import subprocess
import sys
import time

import pytest

import vertibench as vb
from test_service import PURE_PURSUIT, ROOT, binary, service  # noqa: F401 (the fixture)

TAG = "vertibench-test-python-planner:1"


def containers(image):
    """Ids of the containers (running or not) of `image`."""
    out = subprocess.run(["docker", "ps", "-a", "-q", "--filter", f"ancestor={image}"], capture_output=True, text=True)
    return out.stdout.split()


def submit_image(image, tasks, env):
    """`vb-submit image IMAGE --wait`, then its results as CSV (the finished `vb-submit results` process)."""
    r = subprocess.run([binary("VB_SUBMIT_BIN"), "image", image, "--tasks", tasks, "--wait"],
                       capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    sid = re.search(r"submitted (\S+)", r.stdout).group(1)
    r = subprocess.run([binary("VB_SUBMIT_BIN"), "results", sid, "--format", "csv"], capture_output=True,
                       text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr
    return r


def docker_ok():
    if shutil.which("docker") is None:
        return False
    return subprocess.run(["docker", "info"], capture_output=True).returncode == 0


@pytest.fixture(scope="module")
def image():
    if not docker_ok():
        pytest.skip("SKIPPED: Docker is not available here")
    r = subprocess.run([str(ROOT / "deploy" / "build-python-planner-image.sh"), str(PURE_PURSUIT), TAG],
                       capture_output=True, text=True, timeout=900, env=dict(os.environ, PYTHON=sys.executable))
    assert r.returncode == 0, r.stdout + r.stderr
    yield TAG
    subprocess.run(["docker", "image", "rm", "-f", TAG], capture_output=True)


def test_a_python_planner_image_through_the_service(image, service, tmp_path):  # noqa: F811
    url, token = service
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    tasks = "w001-t0,w002-t1"
    try:
        r = submit_image(image, tasks, env)
        # The worker removes each episode's container when the episode ends.
        for _ in range(100):
            if not containers(image):
                break
            time.sleep(0.1)
        assert not containers(image), "containers of finished episodes are removed"
    finally:
        ids = containers(image)
        if ids:
            subprocess.run(["docker", "rm", "-f", *ids], capture_output=True)
    import io

    import pandas as pd

    service_rows = pd.read_csv(io.StringIO(r.stdout)).set_index("task_id").sort_index()
    sys.path.insert(0, str(PURE_PURSUIT.parent))
    from pure_pursuit import PurePursuit

    local, _ = vb.evaluate(PurePursuit(), tasks, out=tmp_path / "local", progress=False)
    assert list(service_rows.outcome) == list(local.set_index("task_id").sort_index().outcome)


PROBE = '''
import socket
import sys

import vertibench as vb
from vertibench.serve import serve

# The worker's coordinator port on the host: a container without network cannot reach it.
try:
    socket.create_connection(("127.0.0.1", {port}), timeout=2).close()
    print("NETWORK REACHABLE", flush=True)
    sys.exit(3)
except OSError as e:
    print(f"network blocked: {{e}}", flush=True)


class Straight(vb.Planner):
    name = "probe"

    def act(self, obs):
        return vb.Action(steering=0.0, throttle=0.5)


serve(Straight())
'''


def test_an_image_planner_has_no_network(service, tmp_path):  # noqa: F811
    if not docker_ok():
        pytest.skip("SKIPPED: Docker is not available here")
    url, token = service
    port = int(url.rsplit(":", 1)[1])
    script = tmp_path / "probe.py"
    script.write_text(PROBE.format(port=port))
    tag = "vertibench-test-probe:1"
    r = subprocess.run([str(ROOT / "deploy" / "build-python-planner-image.sh"), str(script), tag],
                       capture_output=True, text=True, timeout=900, env=dict(os.environ, PYTHON=sys.executable))
    assert r.returncode == 0, r.stdout + r.stderr
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    try:
        r = submit_image(tag, "w001-t0", env)
        assert "planner_failure" not in r.stdout, f"the probe reached the host network: {r.stdout}"
    finally:
        for cid in containers(tag):
            subprocess.run(["docker", "rm", "-f", cid], capture_output=True)
        subprocess.run(["docker", "image", "rm", "-f", tag], capture_output=True)


def test_an_image_the_worker_lacks_waits_for_a_worker_that_has_it(service, tmp_path):  # noqa: F811
    """The worker (vb serve's) has Docker but not this image: it hands the episode back as one it cannot run, so the
    episode stays queued (no attempt used, never failed) for a worker that has the image, and the coordinator says
    why in its log."""
    if not docker_ok():
        pytest.skip("SKIPPED: Docker is not available here")
    url, token = service
    env = dict(os.environ, VB_COORDINATOR=url, VB_TOKEN=token)
    missing = "vertibench-test-no-such-image:0"
    subprocess.run(["docker", "image", "rm", "-f", missing], capture_output=True)
    r = subprocess.run([binary("VB_SUBMIT_BIN"), "image", missing, "--tasks", "w001-t0"],
                       capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    sid = re.search(r"submitted (\S+)", r.stdout).group(1)
    log = tmp_path / "serve.log"
    for _ in range(300):
        if "cannot run a submission" in log.read_text():
            break
        time.sleep(0.1)
    text = log.read_text()
    assert "cannot run a submission" in text and missing in text, text
    # Still waiting, not failed: the episode went back to the queue.
    time.sleep(1.0)
    r = subprocess.run([binary("VB_SUBMIT_BIN"), "status", sid], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr
    assert "0/1 done, 0 running" in r.stdout, r.stdout
    subprocess.run([binary("VB_SUBMIT_BIN"), "cancel", sid], capture_output=True, timeout=60, env=env)
