"""Table 1 of an exported model: `vehloc-eval onnx_path=model.onnx` runs a `.onnx` file of vehloc-export (fp32
or INT8) through onnxruntime on the same test split, and writes the same tables with the same code as a
checkpoint's evaluation, so that the deployed model's figures are measured, not assumed from its checkpoint's."""

from __future__ import annotations

from pathlib import Path

import onnxruntime as ort

from vehloc.data.specs import display_name
from vehloc.errors import VehlocError
from vehloc.hardware import cpu_info
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.labelled import predict_labelled
from vehloc.train.classes import class_info, class_mismatch, read_data
from vehloc.train.params import DataParams
from vehloc.train.report import write_report
from vehloc.train.table1 import ClassTable, evaluate_predictions

PROVIDERS = ["CPUExecutionProvider"]


def evaluate_onnx(onnx_path: str | Path, data: DataParams, out_dir: Path) -> dict[str, float]:
    """Table 1 and the evaluation tables of the model at `onnx_path` on the test split of `data.root`, written
    to `out_dir`; returns the metrics a checkpoint's test logs: `test/acc`, `test/acc_top5` (in [0, 1]) and
    `test/dim_err_pct`, `test/dim_err_pct_expected` (the mean L/W/H % error of each dimension rule)."""
    classifier = VehicleClassifier.from_onnx(onnx_path, PROVIDERS)
    dataset, specs = read_data(data.root, data.specs_csv)
    classes = class_info(dataset, specs)
    mismatch = class_mismatch(  # a model scored on another set numbered alike gives a meaningless Table 1
        "model", [c.model_id for c in classifier.classes], [(c.make, c.model) for c in classifier.classes],
        classes["class_model_ids"], list(zip(classes["class_makes"], classes["class_models"])), f"data.root {data.root}")
    if mismatch:
        raise VehlocError(f"{classifier.source}: {mismatch}")
    if not dataset.test:
        raise VehlocError(f"data.root {data.root}: the test split is empty")
    metadata = classifier.metadata
    predictions = predict_labelled(classifier, dataset.test, progress=f"{Path(onnx_path).name} on the test split")
    names = [display_name(c.make, c.model) for c in classifier.classes]
    table = ClassTable([c.model_id for c in classifier.classes], names, metadata.dims_mm)
    tables = evaluate_predictions(predictions.probabilities, predictions.targets, table, predictions.images,
                                  metadata.expected_top_k)
    write_report(tables, names, out_dir, title=f"Evaluation of {Path(onnx_path).name} on the test split",
                 run_line=f"{metadata.precision.upper()} model, onnxruntime {ort.__version__} on {cpu_info().describe()}.")
    accuracy = tables.accuracy.set_index("metric")["value"]
    dimension_pct = tables.dimension_summary.groupby("rule")["mean_pct"].mean()
    metrics = {"test/acc": accuracy["top1_pct"] / 100.0, "test/acc_top5": accuracy["top5_pct"] / 100.0,
               "test/dim_err_pct": float(dimension_pct["top1"]),
               "test/dim_err_pct_expected": float(dimension_pct["expected"])}
    print(f"{onnx_path} ({metadata.precision}) on {len(dataset.test)} test images of {data.root}: top-1 "
          f"{accuracy['top1_pct']:.2f} %, top-5 {accuracy['top5_pct']:.2f} %; tables in {out_dir}")
    return metrics
