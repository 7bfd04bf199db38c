"""Helpers of the bad-input tests: console scripts run as a user runs them, the one-line error they must end
with, byte-for-byte snapshots of outputs, a read-only file system, and small stand-ins for the trained
artefacts (a vehloc ONNX classifier built by hand, a checkpoint with a class table and no network) so that
the CLIs can be driven into their checks without training anything."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import numpy as np

PROJECT_ROOT = Path(__file__).resolve().parents[1]
CLI_MODULES = {
    "vehloc-data": "vehloc.synth.cli",
    "vehloc-scene": "vehloc.synth.scene_cli",
    "vehloc-calibrate": "vehloc.geometry.pipeline.calibrate_cli",
    "vehloc-export": "vehloc.infer.export_cli",
    "vehloc-predict": "vehloc.infer.predict_cli",
    "vehloc-train": "vehloc.train.train",
    "vehloc-eval": "vehloc.train.evaluate",
    "vehloc-localize": "vehloc.geometry.pipeline.localize_cli",
    "vehloc-demo": "vehloc.demo.cli",
    "vehloc-speed-eval": "vehloc.geometry.pipeline.speed_eval_cli",
}


def cli_env() -> dict[str, str]:
    pythonpath = os.pathsep.join(p for p in (str(PROJECT_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONWARNINGS": "ignore", "PYTHONPATH": pythonpath}


def cli_command(prog: str, *args: str) -> list[str]:
    return [sys.executable, "-m", CLI_MODULES[prog], *map(str, args)]


def run_cli(prog: str, *args: str | Path, cwd: Path | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run a console script as a user does (its module, in a fresh interpreter)."""
    return subprocess.run(cli_command(prog, *map(str, args)), cwd=cwd, env=cli_env(), capture_output=True, text=True,
                          timeout=timeout)


HEAVY_MODULES = ("torch", "lightning", "onnx")


def run_cli_noting_imports(prog: str, *args: str | Path, cwd: Path | None = None,
                           modules: Sequence[str] = HEAVY_MODULES) -> tuple[subprocess.CompletedProcess, str]:
    """Run a console script as `run_cli` does, and say which of `modules` it had imported when it ended
    (comma-separated, in that order; empty when none)."""
    code = ("import atexit, runpy, sys\n"
            f"atexit.register(lambda: print(','.join(m for m in {tuple(modules)!r} if m in sys.modules)))\n"
            f"sys.argv = [{prog!r}, *{[str(a) for a in args]!r}]\n"
            f"runpy.run_module({CLI_MODULES[prog]!r}, run_name='__main__', alter_sys=True)\n")
    result = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=cli_env(), capture_output=True, text=True,
                            timeout=300)
    lines = result.stdout.strip().splitlines()
    return result, lines[-1] if lines else ""


@contextmanager
def side_by_side(runs: Mapping[str, tuple[str, Sequence[str | Path], Path | None]]) -> Iterator[dict[str, Future]]:
    """Start console-script runs (`prog`, its arguments, its working folder) side by side, as many at a time as
    there are CPU cores (a refused run spends its time importing, on one core); yields their futures by name,
    so that each case's test waits for its own result."""
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        yield {name: pool.submit(run_cli, prog, *args, cwd=cwd) for name, (prog, args, cwd) in runs.items()}


def assert_one_error(result: subprocess.CompletedProcess, prog: str, *fragments: str, code: int = 1) -> str:
    """The run ended with exit code `code` and one line on stderr, `<prog>...: error: ...`, holding every
    fragment; return that line."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == code, f"exit {result.returncode}, stderr:\n{result.stderr[-3000:]}"
    assert len(lines) == 1, f"expected one line on stderr, got:\n{result.stderr[-3000:]}"
    line = lines[0]
    assert line.startswith(prog) and ": error: " in line, line
    for fragment in fragments:
        assert fragment in line, f"{fragment!r} not in {line!r}"
    return line


def snapshot(root: Path) -> dict[str, str]:
    """SHA-256 of every file under `root` (hidden ones included), by relative path; of `root` itself when it is a
    file."""
    if root.is_file():
        return {root.name: hashlib.sha256(root.read_bytes()).hexdigest()}
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def leftovers(folder: Path) -> list[str]:
    """Temporary siblings (`.<name>.<pid>.tmp...`, `.<name>.<pid>.old`) left in a folder."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".") and (".tmp" in p.name or p.name.endswith(".old")))


def read_only_supported(folder: Path) -> bool:
    """Whether this machine lets the tests mount `folder` read-only in a private mount namespace (root, or a
    user namespace), so that writing into it fails with EROFS."""
    if not shutil.which("unshare"):
        return False
    script = 'mount --bind "$0" "$0" && mount -o remount,bind,ro "$0" && ! touch "$0/.probe" 2>/dev/null'
    probe = subprocess.run(["unshare", "-m", "sh", "-c", script, str(folder)], capture_output=True)
    return probe.returncode == 0 and not (folder / ".probe").exists()


def run_cli_read_only(folder: Path, prog: str, *args: str | Path) -> subprocess.CompletedProcess:
    """Run a console script with `folder` mounted read-only (a real read-only file system), in a private mount
    namespace that ends with the run."""
    script = 'mount --bind "$0" "$0" && mount -o remount,bind,ro "$0" && exec "$@"'
    return subprocess.run(["unshare", "-m", "sh", "-c", script, str(folder), *cli_command(prog, *map(str, args))],
                          env=cli_env(), capture_output=True, text=True, timeout=300)


def interrupt_when(command: Sequence[str], started: Callable[[], bool], timeout_s: float = 240.0,
                   settle_s: float = 0.3) -> subprocess.CompletedProcess:
    """Start `command` in its own process group, wait until `started()` says it is working, then press Ctrl-C
    as a terminal does (SIGINT to every process of the group); return the finished run."""
    process = subprocess.Popen(command, env=cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    deadline = time.monotonic() + timeout_s
    try:
        while not started():
            if process.poll() is not None:
                out, err = process.communicate()
                raise AssertionError(f"the command ended (exit {process.returncode}) before it was interrupted:\n{err[-3000:]}")
            if time.monotonic() > deadline:
                raise AssertionError("the command did not start working in time")
            time.sleep(0.05)
        time.sleep(settle_s)
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    return subprocess.CompletedProcess(command, process.returncode, out, err)


def write_handmade_onnx(path: Path, model_ids: Sequence[int] = (11, 12, 25), input_size_px: int = 32,
                        metadata_changes: dict | None = None, output_width: int | None = None) -> Path:
    """A small but real vehloc classifier file: images (N, 3, S, S) -> the channel means -> a linear layer ->
    logits and probabilities (N, C), with vehloc metadata for `model_ids` (makes and models named after them).
    `metadata_changes` replaces metadata fields after the fact (to make the file inconsistent);
    `output_width` gives the graph another number of outputs than the classes."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    from vehloc.data.preprocess import Preprocessing
    from vehloc.data.specs import VehicleSpec
    from vehloc.infer.metadata import METADATA_KEY, ModelMetadata

    width = output_width or len(model_ids)
    rng = np.random.default_rng(0)
    weights = numpy_helper.from_array(rng.normal(size=(3, width)).astype(np.float32), "weights")
    bias = numpy_helper.from_array(np.zeros(width, np.float32), "bias")
    nodes = [
        helper.make_node("ReduceMean", ["images"], ["means"], axes=[2, 3], keepdims=0),
        helper.make_node("MatMul", ["means", "weights"], ["scores"]),
        helper.make_node("Add", ["scores", "bias"], ["logits"]),
        helper.make_node("Softmax", ["logits"], ["probabilities"], axis=1),
    ]
    graph = helper.make_graph(
        nodes, "handmade",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, ["N", 3, input_size_px, input_size_px])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, ["N", width]),
         helper.make_tensor_value_info("probabilities", TensorProto.FLOAT, ["N", width])],
        initializer=[weights, bias],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    classes = tuple(VehicleSpec(m, f"Make{m}", f"Model{m}", 4000.0 + m, 1800.0, 1500.0, None) for m in model_ids)
    metadata = ModelMetadata(classes, Preprocessing(input_size_px, input_size_px, 0.1, (0.5, 0.5, 0.5), (0.25, 0.25, 0.25)),
                             "handmade", "0" * 64)
    text = metadata.to_json()
    if metadata_changes:
        import json

        values = json.loads(text)
        for key, value in metadata_changes.items():
            target = values
            *parents, last = key.split(".")
            for parent in parents:
                target = target[int(parent)] if isinstance(target, list) else target[parent]
            target[int(last) if isinstance(target, list) else last] = value
        text = json.dumps(values)
    entry = model.metadata_props.add()
    entry.key, entry.value = METADATA_KEY, text
    onnx.save(model, str(path))
    return path


def write_handmade_checkpoint(path: Path, model_ids: Sequence[int] = (11, 12, 25),
                              makes: Sequence[str] = ("MakeOne", "MakeOne", "MakeTwo"),
                              models: Sequence[str] = ("Alpha", "Beta", "Gamma")) -> Path:
    """A checkpoint file with the class table and preprocessing of a vehloc classifier and no weights: enough
    for every check made before a network is built."""
    import torch

    hyper_parameters = {
        "class_model_ids": list(model_ids), "class_makes": list(makes), "class_models": list(models),
        "class_dims_mm": [[4500.0, 1800.0, 1450.0]] * len(model_ids),
        "backbone": {"name": "googlenet", "pretrained": "none", "aux_logits": True, "dropout": 0.2},
    }
    preprocessing = {"input_size_px": 32, "resize_px": 32, "roi_enlarge_fraction": 0.1,
                     "mean": [0.485, 0.456, 0.406], "std": [0.229, 0.224, 0.225]}
    torch.save({"state_dict": {}, "hyper_parameters": hyper_parameters, "preprocessing": preprocessing}, path)
    return path
