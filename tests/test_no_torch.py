"""The stage cores (sim, desync, labels, frames, graph helpers) must run where torch is not installed."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "d2sr"
CORES = [
    "sim",
    "desync",
    "frames",
    "graphs.py",
    "errors.py",
    "config.py",
    "scene",
    "atomic",
    "runtime",
    "jobs",
    "triggers",
    "synth",
    "ros2",
    "fleet",
    "eval/baselines.py",
    "contract",
    "runtime/pipeline.py",
    "jobs/recordings.py",
    "__init__.py",
    "cli",
    "eval/demo.py",
]


def test_core_sources_do_not_import_torch():
    offenders = []
    for core in CORES:
        path = SRC / core
        assert path.exists(), f"{core}: no such part (renamed? name it here again, or it goes unchecked)"
        for f in [path] if path.is_file() else sorted(path.rglob("*.py")):
            for node in ast.walk(ast.parse(f.read_text())):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.module:
                    names = [node.module]
                offenders += [f"{f.name}: {n}" for n in names if n.split(".")[0] == "torch"]
    assert offenders == []


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_importing_cores_never_loads_torch():
    # A finder that fails any torch import: catches indirect imports through other modules too.
    code = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] == 'torch':
            raise ImportError('torch was imported')
sys.meta_path.insert(0, Block())
import d2sr.sim, d2sr.desync, d2sr.sim.timing, d2sr.eval.desync, d2sr.scene, d2sr.frames.png
import d2sr.sim.rooms, d2sr.sim.interference, d2sr.sim.world, d2sr.sim.record, d2sr.frames.rosbag
from d2sr.sim import OverlapGraph, simulate
simulate(OverlapGraph.complete(2), 'damped', duration_s=2)
assert 'torch' not in sys.modules
print('ok')
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "ok"


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_edge_inference_runs_without_torch(tmp_path):
    """What `pip install '.[edge]'` gives: onnxruntime inference and d2sr detect/recover, no torch."""
    import torch

    from d2sr.models import build
    from d2sr.models.onnx.export import export
    from d2sr.models.store import save_model

    torch.manual_seed(0)
    for name in ("detector", "unet8"):
        save_model(build(name).eval(), name, tmp_path / f"{name}.safetensors")
        export(tmp_path / f"{name}.safetensors", tmp_path / f"{name}.onnx")
    code = f"""
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] == 'torch':
            raise ImportError('torch was imported')
sys.meta_path.insert(0, Block())
import numpy as np
from pathlib import Path
from d2sr.runtime.backends import open_backend
from d2sr.runtime.settings import LoopSettings, RunSettings
from d2sr.contract.repair import repair_frame
from d2sr.eval.baselines import BASELINES
net = open_backend(RunSettings(model='unet8', models=Path({str(tmp_path)!r})))
assert net.name == 'onnxruntime'
x = np.random.default_rng(0).uniform(0.5, 4, (1, 96, 128)).astype(np.float32)
s = net.scores(x)
pred, mask = net.recover(x)
u, _ = repair_frame((x[0] * 1000).astype(np.uint16), pred[0], mask[0], 1000.0)
assert s.shape == (1,) and u.dtype == np.uint16 and 'torch' not in sys.modules
# the closed loop in a simulated room, on the edge backend
from d2sr.jobs.session import run_sim
plan = LoopSettings(controller='damped', sensors=2, seconds=2.0)
summary = run_sim(net, Path({str(tmp_path / "run")!r}), RunSettings(), plan)
assert summary['all']['frames'] == 2 * 2 * 6 and 'torch' not in sys.modules
sys.argv = ['d2sr', '--help']
import d2sr.cli, d2sr.cli.stages, d2sr.cli.run
print('ok')
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "ok"


@pytest.mark.slow  # a subprocess, training or several processes: not in make test-fast
def test_a_command_that_needs_torch_names_the_extra_to_install(tmp_path):
    # As on an edge install (pip install '.[edge]'): torch is simply not there.
    code = """
import sys
class Missing:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] == 'torch':
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Missing())
sys.argv = ['d2sr', 'train', 'recovery', '--out', sys.argv[1]]
from d2sr.cli import main
main()
"""
    res = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "t")], capture_output=True, text=True, check=False
    )
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert "needs torch" in lines[0] and "pip install '.[train]'" in lines[0]
    assert not (tmp_path / "t").exists()
