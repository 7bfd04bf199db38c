"""`vehloc-predict --model m.onnx IMAGE...`: the top-k car models and dimensions of vehicle images.

The images are ROI crops, or, with `--compcars-labels`, whole CompCars images cropped to the box of their
label file (`<root>/image/...jpg` -> `<root>/label/...txt`) enlarged as the model was trained."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from vehloc.atomic import check_output_file, write_text
from vehloc.config import ArgumentParser, integer_argument
from vehloc.data.boxes import Box
from vehloc.data.compcars import parse_label
from vehloc.data.text import read_text
from vehloc.errors import DataError, exit_on_error
from vehloc.infer.classifier import VehicleClassifier

if TYPE_CHECKING:
    import pandas as pd


def label_path_of(image_path: Path) -> Path:
    """The CompCars label file of an image: the last `image` folder of its path replaced by `label`."""
    parts = image_path.parts
    if "image" not in parts[:-1]:
        raise DataError(f"{image_path}: not under an image/ folder of a CompCars root, so it has no label file")
    at = len(parts) - 2 - parts[-2::-1].index("image")
    return Path(*parts[:at], "label", *parts[at + 1:]).with_suffix(".txt")


def label_box(image_path: Path) -> Box:
    """The vehicle box of a CompCars image, from its label file."""
    label_path = label_path_of(image_path)
    if not label_path.is_file():
        raise DataError(f"{label_path}: the label file of {image_path} does not exist")
    try:
        return parse_label(read_text(label_path))[1]
    except ValueError as err:
        raise DataError(f"{label_path}: malformed label: {err}") from None


def prediction_table(
    model: VehicleClassifier, images: list[Path], top_k: int, compcars_labels: bool = False
) -> pd.DataFrame:
    """One row per image and rank: model id, make, model, probability, and the image's dimension estimates.
    With `compcars_labels` each image is classified in the box of its label file (enlarged as in training)."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    boxes = [label_box(image) for image in images] if compcars_labels else None
    rows = []
    for image, prediction in zip(images, model.predict(images, top_k=top_k, boxes=boxes)):
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
    parser = ArgumentParser(prog="vehloc-predict", description=__doc__)
    parser.add_argument("--model", type=Path, required=True, help="a .onnx file written by vehloc-export")
    parser.add_argument("images", type=Path, nargs="+", help="vehicle images (ROI crops)")
    parser.add_argument("--top-k", type=integer_argument(1), default=5,
                        help="how many models to list per image (at most the model's classes)")
    parser.add_argument("--csv", type=Path, help="also write the table to this CSV file (replaced whole)")
    parser.add_argument(
        "--compcars-labels", action="store_true",
        help="the images are whole CompCars images: crop each to the box of its label file",
    )
    args = parser.parse_args(argv)
    if args.csv:
        check_output_file(args.csv, "--csv", [args.model, *args.images])
    missing = [image for image in args.images if not image.is_file()]
    if missing:
        state = "is a folder" if missing[0].is_dir() else "image does not exist"
        raise DataError(f"{missing[0]}: {state}" + (f" (and {len(missing) - 1} more missing)" if len(missing) > 1 else ""))
    table = prediction_table(VehicleClassifier.from_onnx(args.model), args.images, args.top_k, args.compcars_labels)
    print(table.to_string(index=False))
    if args.csv:
        write_text(args.csv, table.to_csv(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
