"""The geometry of monocular vehicle localization, as maths on arrays: the projective transform of the road
plane, the pinhole camera, calibration from lane markers, the background model's vehicle boxes and
silhouettes, the detectors of the paper's key points (footprint lines, plate, wheels), the box's placement on
the road, the model fit, a vehicle's path on the road and the estimates' uncertainty.

It imports no classifier and writes no file: the pipeline above it (`vehloc.geometry.pipeline`) runs it over
videos with the classifier and writes the results. The names below are its API; the rest of each module is
its workings."""

from vehloc.geometry.calibration import Calibration, CalibrationError, CalibrationParams, calibrate, camera_from_homography
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration, read_calibration
from vehloc.geometry.footprint import FootprintLines, FootprintParams, detect_footprint
from vehloc.geometry.keypoints import DetectorParams, Placement, paper_placement
from vehloc.geometry.markers import DetectedMarker, MarkerDetectionParams, detect_markers
from vehloc.geometry.model_fit import FitParams, ModelFit, best_start, fit_model
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.motion import PathHeading, path_heading, recent_path
from vehloc.geometry.placement import VehicleBox, direction_of, facing, heading_of
from vehloc.geometry.plate import Plate, PlateParams, detect_plate
from vehloc.geometry.projective import HorizonError, ProjectiveTransform
from vehloc.geometry.roi import RoiParams, Silhouette, VehicleRoiExtractor, vehicle_silhouette
from vehloc.geometry.silhouette_start import silhouette_start_headings_deg
from vehloc.geometry.site import Site, SiteError, read_site, site_yaml
from vehloc.geometry.truth import CarTruth, SceneTruth, SceneTruthError, read_scene_truth
from vehloc.geometry.uncertainty import Uncertainty
from vehloc.geometry.wheels import WheelParams, Wheels, detect_wheels

__all__ = [
    "Calibration", "CalibrationError", "CalibrationParams", "CameraCalibration", "CarTruth", "DetectedMarker",
    "DetectorParams", "FitParams", "FootprintLines", "FootprintParams", "HorizonError", "MarkerDetectionParams",
    "ModelFit", "NotPlaced", "PathHeading", "PinholeCamera", "Placement", "Plate", "ReasonCode", "PlateParams",
    "ProjectiveTransform", "RoiParams", "SceneTruth", "SceneTruthError", "Silhouette", "Site", "SiteError",
    "Uncertainty", "VehicleBox", "VehicleRoiExtractor", "WheelParams", "Wheels", "best_start", "calibrate",
    "camera_from_homography", "detect_footprint", "detect_markers", "detect_plate", "detect_wheels", "direction_of",
    "facing", "fit_model", "heading_of", "paper_placement", "path_heading", "read_calibration", "read_scene_truth",
    "read_site", "recent_path", "silhouette_start_headings_deg", "site_yaml", "vehicle_silhouette",
]
