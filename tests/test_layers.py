"""The layer contract: data <- train <- infer <- geometry, synth over data and geometry, the localization
benchmark over synth, infer and geometry, the demo application
over them all (training only as a subprocess); deployment (data, infer, geometry, synth) without torch. Checked on the imports written in the source (every `import`, at
module level or inside functions) and on what importing the deployment packages really loads."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vehloc"
UTILITIES = {"errors", "hardware", "config", "atomic", "tables", "conf"}
ALLOWED = {
    "utilities": UTILITIES,
    "data": UTILITIES | {"data"},
    "train": UTILITIES | {"data", "train"},
    "infer": UTILITIES | {"data", "infer"},
    "geometry": UTILITIES | {"data", "infer", "geometry"},
    "synth": UTILITIES | {"data", "geometry", "synth"},
    "benchmark": UTILITIES | {"data", "infer", "geometry", "synth", "benchmark"},
    "demo": UTILITIES | {"data", "train", "infer", "geometry", "synth", "demo"},
}
# the one bridge between training and deployment: export (with training, as it needs torch) turns a checkpoint
# into an ONNX file and checks it with the deployed classifier; vehloc-export's CLI calls it when it runs
EXCEPTIONS = {"vehloc.train.export": {"infer"}, "vehloc.infer.export_cli": {"train"}}
TORCH = {"torch", "torchvision", "lightning", "pytorch_lightning", "torchmetrics"}
TORCH_FREE_LAYERS = {"utilities", "data", "infer", "geometry", "synth", "benchmark", "demo"}


def module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str) -> str:
    part = module.split(".")[1] if "." in module else ""
    return "utilities" if part in UTILITIES or not part else part


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
            if top == root.name and "." in target and target.split(".")[1] not in allowed:
                violations.append(f"{module} ({layer}) imports {target}")
            if top in TORCH and layer in TORCH_FREE_LAYERS and module not in EXCEPTIONS:
                violations.append(f"{module} ({layer}) imports {target}, deployment runs without torch")
    return violations


def test_every_import_follows_the_layers():
    assert layer_violations(PACKAGE) == []


@pytest.mark.parametrize(("module", "source", "expected"), [
    ("geometry/footprint.py", "def f():\n    from vehloc.train.module import LitVehicleClassifier\n",
     "vehloc.geometry.footprint (geometry) imports vehloc.train.module"),
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
    """Importing every module of data, infer (but the CLI of export), geometry and synth leaves torch unloaded."""
    modules = sorted(
        module_name(path, PACKAGE) for path in PACKAGE.rglob("*.py")
        if layer_of(module_name(path, PACKAGE)) in TORCH_FREE_LAYERS and module_name(path, PACKAGE) not in EXCEPTIONS
    )
    assert "vehloc.infer" in modules and "vehloc.geometry.calibration" in modules
    code = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n    importlib.import_module(name)\n"
        f"loaded = sorted(m for m in {sorted(TORCH)!r} if m in sys.modules)\n"
        "print(','.join(loaded))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == ""
