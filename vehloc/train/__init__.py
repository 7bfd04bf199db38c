"""Training and evaluation workbench: Lightning DataModule and LightningModule, backbones, metrics, Table 1, the
export of a checkpoint to ONNX. The names below are its API; each is imported when first used, so that the
settings' checks (`vehloc.train.params`) run before torch is loaded."""

from __future__ import annotations

import importlib

_HOMES = {
    "CompCarsDataModule": "datamodule", "DataParams": "params", "ExportError": "export", "LitVehicleClassifier": "module",
    "ModelParams": "params", "build_backbone": "backbones", "export_checkpoint": "export", "load_classifier": "module",
}
__all__ = sorted(_HOMES)


def __getattr__(name: str) -> object:
    if name not in _HOMES:
        raise AttributeError(f"module 'vehloc.train' has no attribute {name!r}")
    return getattr(importlib.import_module(f"vehloc.train.{_HOMES[name]}"), name)
