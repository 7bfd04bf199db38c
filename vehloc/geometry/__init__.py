"""The geometry of monocular vehicle localization, as maths on arrays: the projective transform of the road plane, the
pinhole camera, calibration from lane markers, the background model's vehicle boxes and silhouettes (with the share
of each outline pixel a vehicle covers, and a shadow's chromaticity where a coloured vehicle's bleeds into it), the
detectors of the paper's key points (footprint lines, plate, wheels), the box's placement on the road, the model fit,
the shadow a shape casts and the shadow beside a vehicle told from it by the road's light, a vehicle's path on the
road, its reference point from its box and model, its speed, the speed benchmark's camera model, the estimates'
uncertainty, and a camera from its traffic (vanishing points from segments, the camera from two of them, its height
from a vehicle's box and shape).

It imports no classifier and writes no file: the pipeline above it (`vehloc.geometry.pipeline`) runs it over
videos with the classifier and writes the results. The names below are its API; the rest of each module is
its workings."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "auto_calibration": ["BoxScale", "RobustScale", "camera_at_height", "camera_from_vanishing_points",
                         "combine_heights", "focal_from_vanishing_points", "height_from_sides"],
    "box_reference": ["box_edge_px", "box_mismatch", "centre_from_box", "shape_edge_px"],
    "brno": ["BrnoCalibration", "brno_calibration", "focal_and_road_plane", "project_to_metres", "road_plane_points"],
    "calibration": ["Calibration", "CalibrationError", "CalibrationParams", "calibrate", "camera_from_homography"],
    "camera": ["PinholeCamera"],
    "camera_calibration": ["CameraCalibration", "read_calibration"],
    "cast_shadow": ["cast_shadow", "fit_cast", "sun_cast"],
    "chroma": ["chromaticity_shift", "colour_change"],
    "edge_coverage": ["edge_coverage"],
    "footprint": ["FootprintLines", "FootprintParams", "detect_footprint"],
    "keypoints": ["DetectorParams", "Placement", "paper_placement"],
    "markers": ["DetectedMarker", "MarkerDetectionParams", "detect_markers"],
    "model_fit": ["FitParams", "ModelFit", "best_start", "coverage", "fit_model", "overlap"],
    "outcome": ["FailedEstimate", "NotPlaced", "ReasonCode"],
    "motion": ["PathHeading", "path_heading", "recent_path"],
    "placement": ["VehicleBox", "direction_of", "facing", "heading_of"],
    "plate": ["Plate", "PlateParams", "detect_plate", "plate_candidates"],
    "projective": ["HorizonError", "ProjectiveTransform"],
    "road_shadow": ["RoadShadow", "fit_road_shadow", "refit_with_restarts", "refit_without_shadow", "shadow_edge_shares",
                    "undecided_edge", "unexplained_outside"],
    "roi": ["RoiParams", "Silhouette", "VehicleRoiExtractor", "vehicle_silhouette"],
    "silhouette_start": ["silhouette_start_headings_deg"],
    "site": ["Site", "SiteError", "read_site", "site_yaml"],
    "speed": ["SpeedFit", "fit_speed"],
    "traffic_evidence": ["FeatureParams", "FeatureTracks", "Outline", "across_candidates", "edge_segments",
                         "road_line_candidates", "sure_outline"],
    "truth": ["CarTruth", "SceneTruth", "SceneTruthError", "read_scene_truth"],
    "uncertainty": ["Uncertainty"],
    "vanishing": ["Segments", "VanishingPoint", "find_vanishing_point", "refine_point"],
    "wheels": ["WheelParams", "Wheels", "detect_wheels"],
})
