"""The layer contract: `data` under all; `train` and `infer` beside each other on `data` (the export and the ONNX
evaluation bridge them);
the geometry maths (`vehloc.geometry`) on `data` only: no classifier, no pipeline, no drawing, no file writer; the
pipeline (`vehloc.geometry.pipeline`) on the geometry and `infer`, never on `train`; `synth` on `data` and the
geometry; the localization benchmark on `synth` and the pipeline; the demo application over them all (training
only as a subprocess); deployment (data, infer, geometry, the pipeline, synth) without torch. Checked on the
imports written in the source (every `import`, at module level or inside functions) and on what importing the
deployment packages really loads."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vehloc"
UTILITIES = {"errors", "hardware", "config", "atomic", "tables", "conf", "api", "multirun", "run_manifest"}
FILE_WRITERS = {"atomic", "run_manifest"}
ALLOWED = {
    "utilities": UTILITIES,
    "data": UTILITIES | {"data"},
    "train": UTILITIES | {"data", "train"},
    "infer": UTILITIES | {"data", "infer"},
    "geometry": UTILITIES - FILE_WRITERS | {"data", "geometry"},
    "pipeline": UTILITIES | {"data", "infer", "geometry", "pipeline"},
    "synth": UTILITIES | {"data", "geometry", "synth"},
    "benchmark": UTILITIES | {"data", "infer", "geometry", "pipeline", "synth", "benchmark"},
    "demo": UTILITIES | {"data", "train", "infer", "geometry", "pipeline", "synth", "demo"},
}
# the bridges between training and deployment: export (with training, as it needs torch) turns a checkpoint
# into an ONNX file and checks it with the deployed classifier; vehloc-export's CLI calls it when it runs; and
# vehloc-eval scores a deployed file with training's Table 1 code (`onnx_eval`)
EXCEPTIONS = {"vehloc.train.export": {"infer"}, "vehloc.infer.export_cli": {"train"}, "vehloc.train.onnx_eval": {"infer"}}
TORCH = {"torch", "torchvision", "lightning", "pytorch_lightning", "torchmetrics"}
TORCH_FREE_LAYERS = {"utilities", "data", "infer", "geometry", "pipeline", "synth", "benchmark", "demo"}


def module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str) -> str:
    """The layer of a vehloc module: its package under `vehloc`, the pipeline apart from the geometry maths, and the
    top-level modules (`vehloc.config`, ...) by their own names, as utilities."""
    parts = module.split(".")
    if parts[1:3] == ["geometry", "pipeline"]:
        return "pipeline"
    part = parts[1] if len(parts) > 1 else ""
    return part if part and part not in UTILITIES else "utilities"


def target_layer(target: str) -> str:
    """The layer an import of `target` reaches: as `layer_of`, with a top-level utility module named as itself."""
    layer = layer_of(target)
    return target.split(".")[1] if layer == "utilities" and "." in target else layer


def imported_modules(path: Path) -> set[str]:
    """Every absolute module name a source file imports, anywhere in it."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def layer_violations(root: Path) -> list[str]:
    """`module imports target` lines for every import that breaks the contract, under package folder `root`."""
    violations = []
    for path in sorted(root.rglob("*.py")):
        module = module_name(path, root)
        layer = layer_of(module)
        allowed = ALLOWED[layer] | EXCEPTIONS.get(module, set())
        for target in sorted(imported_modules(path)):
            top = target.split(".")[0]
            if top == root.name and "." in target and target_layer(target) not in allowed:
                violations.append(f"{module} ({layer}) imports {target}")
            if top in TORCH and layer in TORCH_FREE_LAYERS and module not in EXCEPTIONS:
                violations.append(f"{module} ({layer}) imports {target}, deployment runs without torch")
    return violations


def test_every_import_follows_the_layers():
    assert layer_violations(PACKAGE) == []


@pytest.mark.parametrize(("module", "source", "expected"), [
    ("geometry/footprint.py", "def f():\n    from vehloc.train.module import LitVehicleClassifier\n",
     "vehloc.geometry.footprint (geometry) imports vehloc.train.module"),
    ("geometry/model_fit.py", "from vehloc.geometry.pipeline.localize import Localizer\n",
     "vehloc.geometry.model_fit (geometry) imports vehloc.geometry.pipeline.localize"),
    ("geometry/keypoints.py", "from vehloc.infer.classifier import VehicleClassifier\n",
     "vehloc.geometry.keypoints (geometry) imports vehloc.infer.classifier"),
    ("geometry/placement.py", "from vehloc.geometry.pipeline.drawing import draw_cuboid\n",
     "vehloc.geometry.placement (geometry) imports vehloc.geometry.pipeline.drawing"),
    ("geometry/site.py", "from vehloc.atomic import write_text\n", "vehloc.geometry.site (geometry) imports vehloc.atomic"),
    ("geometry/pipeline/tracker.py", "import vehloc.train.checkpoints\n",
     "vehloc.geometry.pipeline.tracker (pipeline) imports vehloc.train.checkpoints"),
    ("geometry/pipeline/votes.py", "import torch\n",
     "vehloc.geometry.pipeline.votes (pipeline) imports torch, deployment runs without torch"),
    ("data/reader.py", "import vehloc.synth.catalog\n", "vehloc.data.reader (data) imports vehloc.synth.catalog"),
    ("infer/classifier.py", "import torch\n", "vehloc.infer.classifier (infer) imports torch, deployment runs without torch"),
    ("synth/scene.py", "from vehloc.infer import VehicleClassifier\n", "vehloc.synth.scene (synth) imports vehloc.infer"),
    ("benchmark/runner.py", "import vehloc.train.module\n", "vehloc.benchmark.runner (benchmark) imports vehloc.train.module"),
])
def test_a_forbidden_import_is_caught(tmp_path: Path, module: str, source: str, expected: str):
    """The checker run on a copy of the package with one forbidden import added reports exactly that one."""
    copy = tmp_path / "vehloc"
    for path in PACKAGE.rglob("*.py"):
        target = copy / path.relative_to(PACKAGE)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    planted = copy / module
    planted.write_text((planted.read_text(encoding="utf-8") if planted.is_file() else "") + source, encoding="utf-8")
    assert layer_violations(copy) == [expected]


def test_deployment_packages_import_without_torch():
    """Importing every module of data, infer (but the CLI of export), geometry, the pipeline, synth, the benchmark
    and the demo leaves torch unloaded."""
    modules = sorted(
        module_name(path, PACKAGE) for path in PACKAGE.rglob("*.py")
        if layer_of(module_name(path, PACKAGE)) in TORCH_FREE_LAYERS and module_name(path, PACKAGE) not in EXCEPTIONS
    )
    assert {"vehloc.infer", "vehloc.geometry.calibration", "vehloc.geometry.pipeline.localize"} <= set(modules)
    code = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n    importlib.import_module(name)\n"
        f"loaded = sorted(m for m in {sorted(TORCH)!r} if m in sys.modules)\n"
        "print(','.join(loaded))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == ""


CLI_MODULES = ["vehloc.geometry.pipeline.localize_cli", "vehloc.geometry.pipeline.calibrate_cli",
               "vehloc.geometry.pipeline.speed_eval_cli", "vehloc.infer.predict_cli",
               "vehloc.geometry.pipeline.multirun_table"]  # the last: the callback every vehloc-localize run loads


def test_the_deployment_clis_load_no_table_or_plot_library_before_their_work():
    """Importing the deployment CLIs (and the multirun callback Hydra instantiates on every `vehloc-localize`
    run) loads neither pandas nor matplotlib: they are imported where tables and figures are made, so bad input
    is refused in about a second less."""
    code = (
        "import importlib, sys\n"
        f"for name in {CLI_MODULES!r}:\n    importlib.import_module(name)\n"
        "print(','.join(m for m in ('pandas', 'matplotlib') if m in sys.modules))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == ""


def test_every_package_states_its_api():
    """Each package's `__init__` names its API in `__all__`, every name of which it really exports."""
    packages = sorted(module_name(path, PACKAGE) for path in PACKAGE.rglob("__init__.py"))
    assert {"vehloc.geometry", "vehloc.geometry.pipeline"} <= set(packages)
    code = (
        "import importlib\n"
        f"for name in {packages!r}:\n"
        "    module = importlib.import_module(name)\n"
        "    names = getattr(module, '__all__', None)\n"
        "    assert isinstance(names, list), f'{name} has no __all__'\n"
        "    missing = [n for n in names if not hasattr(module, n)]\n"
        "    assert not missing, f'{name} does not export {missing}'\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
