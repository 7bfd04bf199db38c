"""Deployment: self-contained ONNX export of the classifier and the onnxruntime classifier built on it."""

from vehloc.infer.classifier import Prediction, VehicleClassifier

__all__ = ["Prediction", "VehicleClassifier"]
