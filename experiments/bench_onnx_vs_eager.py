"""Batch-1 latency and batch-32 throughput of the exported classifier: onnxruntime against eager
PyTorch, same model, same inputs, measured side by side in one run.

    python experiments/bench_onnx_vs_eager.py --out outputs/bench_onnx [--ckpt path.ckpt] [--size 224]

Without `--ckpt` the paper's network (GoogLeNet, 431 classes as in CompCars) is built with random
weights: timing does not depend on the weights' values. Writes `onnx_vs_eager.csv` and `.md`.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pandas as pd
import torch

from vehloc.train.export import DeployedClassifier
from vehloc.train.module import LitVehicleClassifier, load_classifier, read_checkpoint
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error


def paper_model(num_classes: int, size_px: int) -> LitVehicleClassifier:
    return LitVehicleClassifier(
        class_model_ids=list(range(1, num_classes + 1)), class_makes=["make"] * num_classes,
        class_models=[f"model {i}" for i in range(num_classes)], class_dims_mm=[[4500.0, 1800.0, 1450.0]] * num_classes,
        backbone={"name": "googlenet", "pretrained": "none", "aux_logits": True, "dropout": 0.2},
        optimizer={}, scheduler={}, input_size_px=size_px, eval_resize_px=size_px, roi_enlarge_fraction=0.1,
    )


def _median_ms(function, repeats: int) -> float:
    function()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(1000 * (time.perf_counter() - start))
    return float(np.median(times))


@exit_on_error("experiments/bench_onnx_vs_eager.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_onnx"))
    parser.add_argument("--ckpt", type=Path)
    parser.add_argument("--size", type=int, default=224)
    parser.add_argument("--classes", type=int, default=431)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=30)
    args = parser.parse_args()

    torch.set_num_threads(args.threads)
    model = load_classifier(read_checkpoint(args.ckpt)) if args.ckpt else paper_model(args.classes, args.size)
    size = int(model.hparams.input_size_px)
    deployed = DeployedClassifier(model).eval()
    rng = np.random.default_rng(0)
    batch1 = rng.random((1, 3, size, size), dtype=np.float32)
    batch32 = rng.random((32, 3, size, size), dtype=np.float32)

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.onnx"
        torch.onnx.export(
            deployed, (torch.from_numpy(batch32[:2]),), str(path), input_names=["images"],
            output_names=["logits", "probabilities"], dynamo=True,
            dynamic_shapes=({0: torch.export.Dim("batch", min=1, max=4096)},), external_data=False,
        )
        options = ort.SessionOptions()
        options.intra_op_num_threads = args.threads
        session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])

        def eager(batch: np.ndarray):
            with torch.inference_mode():
                return deployed(torch.from_numpy(batch))

        def onnx(batch: np.ndarray):
            return session.run(None, {"images": batch})

        rows = []
        for name, batch, repeats in (("batch-1 latency", batch1, args.repeats), ("batch-32", batch32, max(5, args.repeats // 5))):
            eager_ms, onnx_ms = _median_ms(lambda: eager(batch), repeats), _median_ms(lambda: onnx(batch), repeats)
            rows.append({
                "measure": name, "eager_ms": eager_ms, "onnxruntime_ms": onnx_ms,
                "eager_img_per_s": 1000 * len(batch) / eager_ms, "onnxruntime_img_per_s": 1000 * len(batch) / onnx_ms,
                "onnxruntime_over_eager_time": onnx_ms / eager_ms,
            })
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "onnx_vs_eager.csv", index=False)
    header = (
        f"GoogLeNet classifier, {size}x{size} px, {model.num_classes} classes, {args.threads} threads, "
        f"median of {args.repeats} (batch 1) / {max(5, args.repeats // 5)} (batch 32) runs\n\n"
    )
    markdown = header + markdown_table(table, "{:.3f}") + "\n"
    (args.out / "onnx_vs_eager.md").write_text(markdown)
    print(markdown)


if __name__ == "__main__":
    main()
