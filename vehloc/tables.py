"""Markdown tables for the reports that runs write beside their CSV files."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd


def markdown_table(frame: pd.DataFrame, float_format: str = "{:.2f}") -> str:
    """A GitHub Markdown table of a frame; floats with `float_format`."""
    def cell(value: object) -> str:
        if isinstance(value, (float, np.floating)):
            return float_format.format(value)
        return str(value)

    lines = ["| " + " | ".join(map(str, frame.columns)) + " |", "|" + "---|" * len(frame.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join(lines)
