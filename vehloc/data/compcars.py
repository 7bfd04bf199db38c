"""Reading, validating and writing the CompCars web-nature layout.

Layout under a root:
  image/<make_id>/<model_id>/<year>/<name>.jpg
  label/<make_id>/<model_id>/<year>/<name>.txt   (viewpoint; number of boxes; `x1 y1 x2 y2`, 1-based)
  train_test_split/classification/{train,test}.txt   (one `make/model/year/name.jpg` per line)
  misc/make_model_name.mat   (cell arrays `make_names`, `model_names`; index i holds id i+1)
  misc/attributes.txt        (optional)

Classes are the model ids of the train list, mapped to contiguous indices in sorted order.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from vehloc.data.attributes import ModelAttributes, read_attributes
from vehloc.data.boxes import Box
from vehloc.data.matfile import read_make_model_names
from vehloc.data.preprocess import ImageInputError, read_bgr
from vehloc.data.text import TextFileError, read_text
from vehloc.errors import DataError

VIEWPOINT_NAMES: dict[int, str] = {
    -1: "uncertain",
    1: "front",
    2: "rear",
    3: "side",
    4: "front-side",
    5: "rear-side",
}
SPLITS = ("train", "test")
SPLIT_DIR = Path("train_test_split") / "classification"
NAMES_FILE = Path("misc") / "make_model_name.mat"
ATTRIBUTES_FILE = Path("misc") / "attributes.txt"


@dataclass(frozen=True)
class CompCarsSample:
    """One image of a split with its label."""

    rel_path: str
    make_id: int
    model_id: int
    year: str
    image_path: Path
    label_path: Path
    viewpoint: int
    box: Box


@dataclass(frozen=True)
class CompCarsSet:
    """A validated CompCars-format data set."""

    root: Path
    train: list[CompCarsSample]
    test: list[CompCarsSample]
    model_ids: tuple[int, ...]
    make_names: dict[int, str] = field(default_factory=dict)
    model_names: dict[int, str] = field(default_factory=dict)
    attributes: dict[int, ModelAttributes] = field(default_factory=dict)

    @property
    def num_classes(self) -> int:
        return len(self.model_ids)

    def split(self, name: str) -> list[CompCarsSample]:
        if name not in SPLITS:
            raise ValueError(f"unknown split {name!r}; expected one of {SPLITS}")
        return self.train if name == "train" else self.test

    def class_index(self, model_id: int) -> int:
        """Contiguous class index of a model id (its position among the sorted train model ids)."""
        return self._index_of_model[model_id]

    @cached_property
    def _index_of_model(self) -> dict[int, int]:
        return {model_id: i for i, model_id in enumerate(self.model_ids)}

    def labels(self, split: str) -> list[int]:
        index = self._index_of_model
        return [index[s.model_id] for s in self.split(split)]

    def make_name_of(self, make_id: int) -> str:
        return self.make_names.get(make_id, f"make {make_id}")

    def model_name_of(self, model_id: int) -> str:
        return self.model_names.get(model_id, f"model {model_id}")

    def class_table(self) -> list[dict[str, object]]:
        """One row per class: index, model id, make id, make and model names."""
        make_of_model = {s.model_id: s.make_id for s in self.train}
        return [
            {
                "class_index": i,
                "model_id": model_id,
                "make_id": make_of_model[model_id],
                "make": self.make_name_of(make_of_model[model_id]),
                "model": self.model_name_of(model_id),
            }
            for i, model_id in enumerate(self.model_ids)
        ]


@dataclass
class ScanResult:
    """What scanning a root found: the data set (when readable), its problems and warnings."""

    dataset: CompCarsSet | None
    problems: list[str]
    warnings: list[str]


def parse_split_line(line: str) -> tuple[int, int, str, str]:
    """Parse `make/model/year/name.jpg` into (make_id, model_id, year, name); ValueError if malformed."""
    parts = line.split("/")
    if len(parts) != 4 or not all(parts):
        raise ValueError(f"expected 'make_id/model_id/year/name.jpg', got {line!r}")
    make, model, year, name = parts
    if not (make.isdigit() and model.isdigit()):
        raise ValueError(f"make and model ids must be integers, got {line!r}")
    return int(make), int(model), year, name


def parse_label(text: str) -> tuple[int, Box]:
    """Parse a label file's text into (viewpoint, box); ValueError naming the bad line."""
    lines = [ln.strip() for ln in text.strip().splitlines()]
    if len(lines) < 3:
        raise ValueError(f"expected 3 lines (viewpoint, box count, box), found {len(lines)}")
    try:
        viewpoint = int(lines[0])
    except ValueError:
        raise ValueError(f"line 1: viewpoint must be an integer, got {lines[0]!r}") from None
    if viewpoint not in VIEWPOINT_NAMES:
        raise ValueError(f"line 1: viewpoint {viewpoint} not in {sorted(VIEWPOINT_NAMES)}")
    try:
        box_count = int(lines[1])
    except ValueError:
        raise ValueError(f"line 2: box count must be an integer, got {lines[1]!r}") from None
    if box_count < 1 or len(lines) < 2 + box_count:
        raise ValueError(f"line 2: declares {box_count} box(es), file has {len(lines) - 2} box line(s)")
    fields = lines[2].split()
    if len(fields) != 4 or not all(f.lstrip("-").isdigit() for f in fields):
        raise ValueError(f"line 3: expected 4 integers 'x1 y1 x2 y2', got {lines[2]!r}")
    x1, y1, x2, y2 = (int(f) for f in fields)
    if x1 < 1 or y1 < 1 or x2 < x1 or y2 < y1:
        raise ValueError(f"line 3: box {x1} {y1} {x2} {y2} is not a 1-based box with x1<=x2, y1<=y2")
    return viewpoint, Box.from_compcars_label(x1, y1, x2, y2)


def _read_split(root: Path, split: str, problems: list[str]) -> list[CompCarsSample] | None:
    """The samples of a split list, every problem appended to `problems`; None when the list itself is
    missing or unreadable."""
    split_path = root / SPLIT_DIR / f"{split}.txt"
    if not split_path.is_file():
        problems.append(f"{split_path}: split list missing")
        return None
    try:
        text = read_text(split_path)
    except TextFileError as err:
        problems.append(str(err))
        return None
    samples = []
    seen: set[str] = set()
    for line_no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        where = f"{split_path}:{line_no}"
        try:
            make_id, model_id, year, name = parse_split_line(line)
        except ValueError as exc:
            problems.append(f"{where}: {exc}")
            continue
        if line in seen:
            problems.append(f"{where}: {line} listed twice")
            continue
        seen.add(line)
        image_path = root / "image" / line
        label_path = (root / "label" / line).with_suffix(".txt")
        if not image_path.is_file():
            problems.append(f"{where}: image {image_path} missing")
            continue
        if not label_path.is_file():
            problems.append(f"{where}: label {label_path} missing")
            continue
        try:
            viewpoint, box = parse_label(read_text(label_path))
        except TextFileError as exc:
            problems.append(f"{exc} (a label file)")
            continue
        except ValueError as exc:
            problems.append(f"{label_path}: malformed label: {exc}")
            continue
        samples.append(
            CompCarsSample(line, make_id, model_id, year, image_path, label_path, viewpoint, box)
        )
    return samples


def scan_compcars(root: Path | str) -> ScanResult:
    """Read and validate a CompCars-format root, collecting every problem with file and line."""
    root = Path(root)
    if not root.is_dir():
        return ScanResult(None, [f"{root}: data root does not exist or is not a folder"], [])
    problems: list[str] = []
    warnings: list[str] = []
    train_read = _read_split(root, "train", problems)
    test_read = _read_split(root, "test", problems)
    train, test = train_read or [], test_read or []
    model_ids = tuple(sorted({s.model_id for s in train}))
    split_path = root / SPLIT_DIR / "test.txt"
    if train_read is not None:  # when the train list itself is unreadable, that is the one problem to name
        test_only = sorted({s.model_id for s in test} - set(model_ids))
        for model_id in test_only:
            first = next(s for s in test if s.model_id == model_id)
            problems.append(f"{split_path}: model {model_id} ({first.rel_path}) is absent from train")
        if not train:
            problems.append(f"{root / SPLIT_DIR / 'train.txt'}: no usable images")
    overlap = sorted({s.rel_path for s in train} & {s.rel_path for s in test})
    for rel_path in overlap:
        problems.append(f"{split_path}: {rel_path} is listed in both train and test")

    make_names: dict[int, str] = {}
    model_names: dict[int, str] = {}
    names_path = root / NAMES_FILE
    if names_path.is_file():
        try:
            make_names, model_names = read_make_model_names(names_path)
        except DataError as exc:
            problems.extend(exc.problems or [exc.summary])
        for model_id in model_ids:
            if model_names and model_id not in model_names:
                problems.append(f"{names_path}: no model name for model {model_id}")
    else:
        warnings.append(f"{names_path}: missing; classes are named by their ids")

    attributes: dict[int, ModelAttributes] = {}
    attributes_path = root / ATTRIBUTES_FILE
    if attributes_path.is_file():
        try:
            attributes = read_attributes(attributes_path)
        except DataError as exc:
            problems.extend(exc.problems or [exc.summary])

    dataset = CompCarsSet(root, train, test, model_ids, make_names, model_names, attributes)
    return ScanResult(dataset, problems, warnings)


def read_compcars(root: Path | str) -> CompCarsSet:
    """Read a CompCars-format root; raise DataError listing every problem if it has any."""
    result = scan_compcars(root)
    if result.problems or result.dataset is None:
        raise DataError(f"{root}: {len(result.problems)} problem(s) in CompCars data", result.problems)
    return result.dataset


def check_images(samples: Sequence[CompCarsSample]) -> list[str]:
    """Decode every image with the one image reader (which also finds truncated and corrupt files); report
    unreadable ones and boxes that leave the image."""
    problems = []
    for sample in samples:
        try:
            image = read_bgr(sample.image_path, strict=True)
        except ImageInputError as err:
            problems.append(str(err))
            continue
        height_px, width_px = image.shape[:2]
        if sample.box.clipped(width_px, height_px) != sample.box:
            x1, y1, x2, y2 = sample.box.to_compcars_label()
            problems.append(
                f"{sample.label_path}: box {x1} {y1} {x2} {y2} leaves the {width_px}x{height_px} image"
            )
    return problems


def summarize(dataset: CompCarsSet) -> str:
    """A human-readable summary: classes, images per split, viewpoints, box sizes."""
    lines = [
        f"root: {dataset.root}",
        f"classes: {dataset.num_classes}",
        f"makes: {len({s.make_id for s in dataset.train})}",
    ]
    for split in SPLITS:
        samples = dataset.split(split)
        lines.append(f"{split}: {len(samples)} images")
        if not samples:
            continue
        per_class = Counter(s.model_id for s in samples)
        lines.append(
            f"  images per class: min {min(per_class.values())}, max {max(per_class.values())}"
        )
        views = Counter(s.viewpoint for s in samples)
        view_text = ", ".join(f"{VIEWPOINT_NAMES[v]} {views[v]}" for v in sorted(views))
        lines.append(f"  viewpoints: {view_text}")
        widths = np.array([s.box.width_px for s in samples])
        heights = np.array([s.box.height_px for s in samples])
        lines.append(
            "  box width px: min {} / median {:.0f} / max {}; height px: min {} / median {:.0f} / max {}".format(
                widths.min(), np.median(widths), widths.max(),
                heights.min(), np.median(heights), heights.max(),
            )
        )
    return "\n".join(lines)


def write_label(path: Path, viewpoint: int, box: Box) -> None:
    """Write a one-box label file: viewpoint, `1`, `x1 y1 x2 y2` (1-based, inclusive)."""
    if viewpoint not in VIEWPOINT_NAMES:
        raise ValueError(f"viewpoint {viewpoint} not in {sorted(VIEWPOINT_NAMES)}")
    if box.is_empty or box.x0 < 0 or box.y0 < 0:
        raise ValueError(f"box {box.as_tuple()} is empty or starts outside the image")
    path.parent.mkdir(parents=True, exist_ok=True)
    x1, y1, x2, y2 = box.to_compcars_label()
    path.write_text(f"{viewpoint}\n1\n{x1} {y1} {x2} {y2}\n")


def write_split_list(path: Path, rel_image_paths: Sequence[str]) -> None:
    """Write a split list, one `make/model/year/name.jpg` per line."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(f"{p}\n" for p in rel_image_paths))
