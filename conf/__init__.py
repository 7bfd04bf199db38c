"""vehloc's Hydra configs, installed with the package as `vehloc.conf` (located by `vehloc.config.config_dir`)."""
