"""Task sets from Python: the benchmark's carried by the package (written into the cache, never read from the
source tree), training sets generated from a seed with the same bytes as ``vb tasks generate``."""

import json
import os
import subprocess
from pathlib import Path

import pytest

import vertibench as vb

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / "tasks" / "data" / "v4"


def files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_the_benchmark_set_comes_from_the_package_into_the_cache_not_from_the_source_tree():
    d = vb.tasks.benchmark()
    cache = Path(os.environ["VERTIBENCH_CACHE"])
    assert d.is_relative_to(cache) and not d.is_relative_to(ROOT)
    assert d.name == vb.tasks.benchmark_version()
    # The package carries the committed set, byte for byte.
    assert files(d) == files(COMMITTED)
    assert json.loads((COMMITTED / "manifest.json").read_text())["version"] == vb.tasks.benchmark_version()
    info = vb.tasks.info(d)
    assert (info.seed, info.worlds) == (vb.tasks.BENCHMARK_SEED, 100)
    # Environments and evaluations default to it.
    assert Path(vb.default_task_set()) == d
    assert vb.make("w017-t3")._core.task_set_version == info.version


def test_a_damaged_cached_benchmark_set_is_replaced():
    d = vb.tasks.benchmark()
    world = d / "worlds" / "017.json"
    world.write_text(world.read_text().replace('"id"', '"id" ', 1))
    with pytest.raises(ValueError, match="hash to"):
        vb.tasks.info(d)
    assert vb.tasks.benchmark() == d
    assert files(d) == files(COMMITTED)


def test_generating_the_benchmark_seed_reproduces_the_committed_set_byte_for_byte(tmp_path):
    info = vb.tasks.generate(seed=vb.tasks.BENCHMARK_SEED, out=tmp_path / "set")
    assert info.version == vb.tasks.benchmark_version()
    assert files(tmp_path / "set") == files(COMMITTED)


def test_generate_gives_the_same_bytes_as_vb_tasks_generate(tmp_path):
    vb_bin = os.environ.get("VB_BIN")
    if not vb_bin:
        pytest.skip("SKIPPED: VB_BIN (the vb binary) is unset: cannot compare with `vb tasks generate`")
    py = vb.tasks.generate(seed=7, out=tmp_path / "py")
    subprocess.run([vb_bin, "tasks", "generate", "--seed", "7", "--out", str(tmp_path / "cli")], check=True,
                   capture_output=True, timeout=600)
    assert files(tmp_path / "py") == files(tmp_path / "cli")
    pyd = vb.tasks.generate(seed=7, out=tmp_path / "py-d", surface="deformable")
    subprocess.run([vb_bin, "tasks", "generate", "--seed", "7", "--surface", "deformable", "--out",
                    str(tmp_path / "cli-d")], check=True, capture_output=True, timeout=600)
    assert files(tmp_path / "py-d") == files(tmp_path / "cli-d")
    assert pyd.generator.endswith("surface=deformable") and pyd.version != py.version


def test_training_sets_are_generated_once_held_out_and_reused(capfd):
    d = vb.tasks.training()
    capfd.readouterr()
    info = vb.tasks.info(d)
    assert info.seed == vb.tasks.TRAINING_SEED and info.version != vb.tasks.benchmark_version()
    assert vb.tasks.training() == d
    assert "generating" not in capfd.readouterr().err
    # Keyed by the seed and the benchmark set's version, whoever made it first.
    assert d.name == f"seed-7@{vb.tasks.benchmark_version()}"
    # The README's training snippet, after pip install alone.
    envs = vb.make_vec(2, tasks="low+rigid", task_set=vb.tasks.training(), crop_size=8)
    obs, _ = envs.reset(seed=0)
    assert obs["elevation"].shape == (2, 8, 8) and envs.task_set_version == info.version


def test_task_set_options_are_checked_with_their_names(tmp_path):
    with pytest.raises(ValueError, match="seed=-1"):
        vb.tasks.generate(seed=-1, out=tmp_path / "x")
    with pytest.raises(TypeError, match="seed='7'"):
        vb.tasks.generate(seed="7", out=tmp_path / "x")
    with pytest.raises(ValueError, match="surface='lava'"):
        vb.tasks.generate(seed=7, out=tmp_path / "x", surface="lava")
    with pytest.raises(ValueError, match="benchmark's own seed"):
        vb.tasks.training(vb.tasks.BENCHMARK_SEED)
    with pytest.raises(ValueError, match="manifest.json"):
        vb.tasks.info(tmp_path / "nowhere")
    with pytest.raises(TypeError):
        vb.tasks.generate(7, tmp_path / "x")  # keyword-only: seed= and out= are named at the call
