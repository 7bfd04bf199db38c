"""vehloc: monocular vehicle localization aided by fine-grained vehicle-model classification."""

__all__ = ["__version__"]

__version__ = "0.1.0"
