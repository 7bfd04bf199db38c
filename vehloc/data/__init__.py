"""CompCars-format data sets and the vehicle specifications table: reading and writing the folders, the specs
and shapes of each model, the one box convention, the one preprocessing and the dimension error. The names below are
its API."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "boxes": ["Box"],
    "compcars": ["CompCarsSample", "CompCarsSet", "read_compcars"],
    "dimension_error": ["DimensionErrors", "dimension_errors"],
    "preprocess": ["ImageInputError", "Preprocessing", "read_bgr"],
    "shapes": ["VehicleShape", "read_shapes"],
    "specs": ["SpecsTable", "VehicleSpec", "read_specs_csv"],
})
