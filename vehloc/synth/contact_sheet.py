"""A contact sheet of a CompCars-format root: one row per model, images over several viewpoints."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np

from vehloc.atomic import write_image
from vehloc.data.compcars import CompCarsSample, read_compcars
from vehloc.data.preprocess import ImageInputError, read_bgr
from vehloc.errors import DataError

CELL_PX = (160, 120)
LABEL_WIDTH_PX = 190
_VIEWPOINT_ORDER = (1, 4, 3, 5, 2, -1)
_BACKGROUND_BGR = (245, 245, 245)


def _spread_viewpoints(samples: list[CompCarsSample], count: int) -> list[CompCarsSample]:
    """Up to ``count`` samples, taken in turn from each viewpoint (front, front-side, side, ...)."""
    by_view: dict[int, list[CompCarsSample]] = defaultdict(list)
    for sample in sorted(samples, key=lambda s: s.rel_path):
        by_view[sample.viewpoint].append(sample)
    queues = [by_view[v] for v in _VIEWPOINT_ORDER if by_view[v]]
    chosen: list[CompCarsSample] = []
    while len(chosen) < count and any(queues):
        for queue in queues:
            if queue and len(chosen) < count:
                chosen.append(queue.pop(0))
    return chosen


def _cell(image_path: Path) -> np.ndarray:
    """The image letterboxed into one cell."""
    try:
        image = read_bgr(image_path)
    except ImageInputError as err:
        raise DataError(str(err)) from None
    cell_w, cell_h = CELL_PX
    scale = min((cell_w - 4) / image.shape[1], (cell_h - 4) / image.shape[0])
    size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
    resized = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    cell = np.full((cell_h, cell_w, 3), _BACKGROUND_BGR, np.uint8)
    x0, y0 = (cell_w - size[0]) // 2, (cell_h - size[1]) // 2
    cell[y0 : y0 + size[1], x0 : x0 + size[0]] = resized
    return cell


def _label(lines: list[str]) -> np.ndarray:
    panel = np.full((CELL_PX[1], LABEL_WIDTH_PX, 3), _BACKGROUND_BGR, np.uint8)
    for i, text in enumerate(lines):
        scale = 0.5 if i == 0 else 0.4
        cv2.putText(
            panel, text, (6, 40 + 22 * i), cv2.FONT_HERSHEY_SIMPLEX, scale, (20, 20, 20), 1, cv2.LINE_AA
        )
    return panel


def write_contact_sheet(root: Path, out_png: Path, per_model: int = 8) -> Path:
    """Draw one row per model of a CompCars-format root, labelled with its name, into ``out_png``."""
    dataset = read_compcars(Path(root))
    by_model: dict[int, list[CompCarsSample]] = defaultdict(list)
    for sample in dataset.train + dataset.test:
        by_model[sample.model_id].append(sample)
    rows = []
    for model_id in sorted(by_model):
        samples = by_model[model_id]
        chosen = _spread_viewpoints(samples, per_model)
        name = dataset.model_name_of(model_id)
        make = dataset.make_name_of(samples[0].make_id)
        if name.startswith(make):
            name = name[len(make) :].strip() or name
        views = sorted({s.viewpoint for s in chosen})
        lines = [make, name, f"model {model_id}: {len(samples)} images", "views " + " ".join(map(str, views))]
        cells = [_cell(s.image_path) for s in chosen]
        cells += [np.full((CELL_PX[1], CELL_PX[0], 3), _BACKGROUND_BGR, np.uint8)] * (per_model - len(cells))
        rows.append(np.hstack([_label(lines)] + cells))
    return write_image(out_png, np.vstack(rows))
