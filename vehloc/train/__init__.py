"""Training and evaluation workbench: Lightning DataModule and LightningModule, backbones, metrics, Table 1."""
