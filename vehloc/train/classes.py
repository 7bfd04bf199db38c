"""The classes of a data set as the classifier sees them (torch-free): the CompCars-format root and its specs
table read and checked, and the class table (model ids, make and model names, dimensions) in class-index
order, the one a checkpoint carries and is compared with."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vehloc.data.compcars import CompCarsSet, read_compcars
from vehloc.data.specs import SpecsTable, read_specs_csv
from vehloc.errors import DataError


def read_dataset(root: str | Path) -> CompCarsSet:
    """The CompCars-format data set at `root`; DataError naming it when it is not there or has problems."""
    root = Path(root)
    if not root.is_dir():
        state = "is a file, not a folder" if root.exists() else "no such folder"
        raise DataError(
            f"data.root {root}: {state} (write the demo set with `vehloc-data make-demo {root}`, or pass "
            "data.root=PATH)"
        )
    return read_compcars(root)


def read_data(root: str | Path, specs_csv: str | Path | None = None) -> tuple[CompCarsSet, SpecsTable]:
    """The data set at `root` and its specs table (`specs_csv`, by default `specs.csv` in the root), read and
    checked to cover every class; DataError naming the first problem."""
    dataset = read_dataset(root)
    return dataset, read_specs(specs_csv or Path(root) / "specs.csv", dataset)


def read_specs(specs_path: str | Path, dataset: CompCarsSet) -> SpecsTable:
    """The specs table, checked to cover every class of `dataset`."""
    specs = read_specs_csv(specs_path)
    specs.require(dataset.model_ids, dataset.model_names)
    return specs


def class_info(dataset: CompCarsSet, specs: SpecsTable) -> dict[str, list]:
    """Model ids, make and model names, (L, W, H) and wheelbase in mm of the classes, in class-index order."""
    table = dataset.class_table()
    return {
        "class_model_ids": [int(row["model_id"]) for row in table],
        "class_makes": [str(row["make"]) for row in table],
        "class_models": [str(row["model"]) for row in table],
        "class_dims_mm": specs.dims_mm(dataset.model_ids).tolist(),
        "class_wheelbases_mm": [specs[m].wheelbase_mm for m in dataset.model_ids],
    }


def class_mismatch(
    holder: str, model_ids: Sequence[int], names: Sequence[tuple[str, str]], data_model_ids: Sequence[int],
    data_names: Sequence[tuple[str, str]] | None, data_name: str,
) -> str | None:
    """How a classifier's classes (`holder`: "checkpoint", "model") differ from a data set's, or None when they are
    the same model ids in the same order with, where `data_names` is given, the same (make, model) names."""
    trained = [int(m) for m in model_ids]
    data = [int(m) for m in data_model_ids]
    if trained != data:
        detail = ""
        only_holder = sorted(set(trained) - set(data))
        only_data = sorted(set(data) - set(trained))
        if only_holder or only_data:
            detail = (f"; only in the {holder}: {_abbrev(only_holder) or 'none'}, "
                      f"only in {data_name}: {_abbrev(only_data) or 'none'}")
        return (f"{holder} has {len(trained)} classes (model ids {_abbrev(trained)}), "
                f"{data_name} has {len(data)} (model ids {_abbrev(data)}){detail}")
    if data_names is None:
        return None
    differing = [(m, a, b) for m, a, b in zip(trained, names, data_names) if tuple(a) != tuple(b)]
    if not differing:
        return None
    model_id, (make_a, model_a), (make_b, model_b) = differing[0]
    return (f"the {holder}'s classes are not those of {data_name}: the model ids match but "
            f"{len(differing)} of {len(trained)} names differ, e.g. model {model_id} is '{make_a} {model_a}' in the "
            f"{holder} and '{make_b} {model_b}' in {data_name} (another data set numbered the same way?)")


def _abbrev(ids: Sequence[int], shown: int = 6) -> str:
    head = ", ".join(map(str, ids[:shown]))
    return head + (f", ... ({len(ids)} in all)" if len(ids) > shown else "")
