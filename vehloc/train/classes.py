"""The classes of a data set as the classifier sees them (torch-free): the CompCars-format root and its specs
table read and checked, and the class table (model ids, make and model names, dimensions) in class-index
order, the one a checkpoint carries and is compared with."""

from __future__ import annotations

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
