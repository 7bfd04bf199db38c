"""Hydra launcher configs (hydra/launcher/*.yaml), on the search path of vehloc-train, vehloc-eval and vehloc-localize."""
