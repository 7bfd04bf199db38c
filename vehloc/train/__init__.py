"""Training and evaluation workbench: Lightning DataModule and LightningModule, backbones, metrics, Table 1, the
export of a checkpoint to ONNX. The names below are its API; each is imported when first used, so that the
settings' checks (`vehloc.train.params`) run before torch is loaded."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "backbones": ["build_backbone"],
    "datamodule": ["CompCarsDataModule"],
    "export": ["ExportError", "export_checkpoint"],
    "module": ["LitVehicleClassifier", "load_classifier"],
    "params": ["DataParams", "ModelParams"],
})
