"""`notebooks/walkthrough.ipynb` runs as stored (nbclient), on its own tiny settings, and leaves what it says it
makes: the demo set, Table 1, the ONNX model, the calibrated and localized scene with its Table 2."""

from __future__ import annotations

from pathlib import Path

import nbformat
import pandas as pd
import pytest
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "walkthrough.ipynb"

pytestmark = pytest.mark.slow  # a demo set, one epoch, an export, one scene rendered, calibrated and localized


def test_the_notebook_is_stored_without_outputs() -> None:
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code and all(not cell.outputs and cell.execution_count is None for cell in code)


def test_the_walkthrough_runs_from_the_demo_set_to_the_birds_eye_view(tmp_path: Path) -> None:
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    NotebookClient(notebook, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    work = tmp_path / "walkthrough_out"
    assert (work / "model.onnx").is_file() and (work / "train" / "table1" / "table1.csv").is_file()
    table2 = pd.read_csv(work / "table2_plate_middle_0" / "localize" / "table2.csv")
    assert list(table2["method"]) == ["paper", "fit"] and set(table2["status"]) == {"localized"}
    assert table2["key_point"].iloc[0] == "plate"  # the paper placement; the fit starts from it
    images = [output for cell in notebook.cells if cell.cell_type == "code" for output in cell.outputs
              if output.get("output_type") == "display_data" and "image/png" in output.get("data", {})]
    assert len(images) == 2  # the demo images and the localization figure
