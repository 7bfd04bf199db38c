"""`vehloc-predict --model m.onnx IMAGE...`: the top-k car models and dimensions of vehicle images."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from vehloc.errors import exit_on_error
from vehloc.infer.classifier import VehicleClassifier


def prediction_table(model: VehicleClassifier, images: list[Path], top_k: int) -> pd.DataFrame:
    """One row per image and rank: model id, make, model, probability, and the image's dimension estimates."""
    rows = []
    for image, prediction in zip(images, model.predict(images, top_k=top_k)):
        for rank, candidate in enumerate(prediction.top_k, start=1):
            rows.append({
                "image": str(image), "rank": rank, "model_id": candidate.model_id, "make": candidate.make,
                "model": candidate.model, "probability": round(candidate.probability, 4),
                **{f"top1_{d}_mm": round(float(v)) for d, v in zip(("length", "width", "height"), prediction.top1_dims_mm)},
                **{f"expected_{d}_mm": round(float(v)) for d, v in zip(("length", "width", "height"), prediction.expected_dims_mm)},
            })
    return pd.DataFrame(rows)


@exit_on_error("vehloc-predict")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="vehloc-predict", description=__doc__)
    parser.add_argument("--model", type=Path, required=True, help="a .onnx file written by vehloc-export")
    parser.add_argument("images", type=Path, nargs="+", help="vehicle images (ROI crops)")
    parser.add_argument("--top-k", type=int, default=5)
    parser.add_argument("--csv", type=Path, help="also write the table to this CSV file")
    args = parser.parse_args(argv)
    table = prediction_table(VehicleClassifier.from_onnx(args.model), args.images, args.top_k)
    print(table.to_string(index=False))
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.csv, index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
