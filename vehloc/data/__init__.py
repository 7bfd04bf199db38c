"""CompCars-format data sets and the vehicle specifications table: reading and writing the folders, the specs
and shapes of each model, the one box convention, the one preprocessing and the dimension error. The names below are
its API."""

from vehloc.data.boxes import Box
from vehloc.data.compcars import CompCarsSample, CompCarsSet, read_compcars
from vehloc.data.dimension_error import DimensionErrors, dimension_errors
from vehloc.data.preprocess import ImageInputError, Preprocessing, read_bgr
from vehloc.data.shapes import VehicleShape, read_shapes
from vehloc.data.specs import SpecsTable, VehicleSpec, read_specs_csv

__all__ = [
    "Box", "CompCarsSample", "CompCarsSet", "DimensionErrors", "ImageInputError", "Preprocessing", "SpecsTable",
    "VehicleShape", "VehicleSpec", "dimension_errors", "read_bgr", "read_compcars", "read_shapes", "read_specs_csv",
]
