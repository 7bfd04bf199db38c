"""Loggers of the workbench."""

from __future__ import annotations

import csv
import os
from typing import Any

from lightning.pytorch.loggers import CSVLogger as LightningCSVLogger


class CSVLogger(LightningCSVLogger):
    """Lightning's CSVLogger, keeping the columns already in `metrics.csv` when its writer starts again on
    an existing file, as it does in every process that `ddp_spawn` starts for fit and then for test."""

    @property
    def experiment(self) -> Any:
        writer = super().experiment
        path = getattr(writer, "metrics_file_path", None)
        if path and not writer.metrics_keys and os.path.isfile(path):
            with open(path, newline="") as handle:
                writer.metrics_keys = sorted(next(csv.reader(handle), []))
        return writer
