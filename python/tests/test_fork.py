"""Fork safety: the extension keeps no thread alive between calls that a forked child would miss (rayon's global
pool is never used), so gymnasium's ``AsyncVectorEnv`` works with every start method and a vector environment made
before a fork keeps working in the child. Each case runs in a subprocess with a timeout, so a hang fails the test
instead of hanging the suite."""

import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import os, sys
    import gymnasium as gym
    import numpy as np
    import vertibench as vb

    def make():
        return gym.make("vertibench/Nav-v0", tasks="low", max_time=5.0)

    if __name__ == "__main__":
        method = sys.argv[1]
        # The parent uses the extension before it forks: loads worlds, steps a vector on its threads.
        parent = vb.make_vec(2, tasks="w001-t0,w001-t1", num_threads=2)
        parent.reset(seed=0)
        parent.step(np.zeros((2, 3)))
        envs = gym.vector.AsyncVectorEnv([make, make], context=method)
        obs, _ = envs.reset(seed=0)
        for _ in range(5):
            obs, *_ = envs.step(np.tile([0.0, 0.5, 0.0], (2, 1)).astype(np.float32))
        assert obs["state"].shape == (2, 15)
        envs.close()
        if method == "fork":
            pid = os.fork()
            if pid == 0:
                child = vb.make_vec(2, tasks="w001-t0,w001-t1", num_threads=2)
                child.reset(seed=0)
                child.step(np.zeros((2, 3)))
                parent.reset(seed=1)                 # the parent's vector, in the child
                parent.step(np.zeros((2, 3)))
                os._exit(0)
            _, status = os.waitpid(pid, 0)
            assert status == 0, status
        print("ok", method)
""")


@pytest.mark.parametrize("method", ["fork", "spawn", "forkserver"])
def test_async_vector_env_and_a_forked_child_work(tmp_path, method):
    script = tmp_path / "fork_case.py"
    script.write_text(SCRIPT)
    r = subprocess.run([sys.executable, str(script), method], capture_output=True, text=True, timeout=240)
    assert r.returncode == 0 and f"ok {method}" in r.stdout, r.stdout + r.stderr
