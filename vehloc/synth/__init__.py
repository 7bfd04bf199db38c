"""Procedural car catalog and renderer: the embedded demo data (CompCars-format images, traffic scenes)."""
