"""The localization pipeline: the geometry of `vehloc.geometry` run over a video with the classifier. The
frames' vehicle boxes are followed by the tracker (one `VehicleTrack` per vehicle, removed when lost), each
track's crops are voted on once, the stopped (or every) vehicle is placed and fitted, and each outcome is a
`VehicleRecord`; every finished track becomes a `VehicleSpeed` (path, speed, lane; its model checked against its
boxes' height; a vehicle of no likely model's size measured by its box's bottom); around it the video reading, the
records' and speeds' files and pictures, the speed benchmark's files and scoring, Table 2 against a scene's truth,
the site calibration's files, the automatic calibration from a video's traffic and its files, and the `vehloc-localize`, `vehloc-calibrate` and `vehloc-speed-eval` CLIs. The names
below are its API."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "auto_calibrate": ["AutoCalibration", "AutoCalibrationParams", "TrafficEvidence", "VehicleHeight", "VehicleModel",
                       "auto_calibrate", "collect_traffic", "mean_size_model", "recognised_models"],
    "auto_calibration_files": ["draw_auto_calibration", "write_auto_calibration_files"],
    "brno_files": ["BrnoCar", "BrnoFileError", "BrnoResults", "GroundTruth", "read_ground_truth", "read_results",
                   "results_json"],
    "evaluation": ["table2_rows", "write_table2"],
    "localize": ["Estimate", "Localizer", "Status", "VehicleRecord", "localize_frames"],
    "model_choice": ["BoxHeightReference", "box_height_reference", "choose_models"],
    "settings": ["LocalizeSettings", "PipelineParams"],
    "site_calibration": ["SiteCalibration", "calibrate_site", "write_calibration_files"],
    "speed_eval": ["SpeedScore", "score_speeds"],
    "speed_files": ["write_speed_files"],
    "speed_report": ["write_score"],
    "table2": ["PoseError", "pose_error"],
    "timing": ["StageClock"],
    "track_speed": ["ModelCandidate", "ModelSource", "SpeedParams", "SpeedStatus", "TrackSpeeds", "VehiclePath",
                    "VehicleSpeed", "assign_lanes"],
    "tracker": ["StoppedVehicleTracker", "TrackerParams", "TrackerUpdate", "TrackState", "VehicleTrack"],
    "travel": ["Travel", "track_travel"],
    "unknown_vehicles": ["apart_from_known"],
    "video": ["MediaError", "VideoInfo", "iter_frames", "read_still", "video_info"],
    "video_localization": ["VideoLocalization", "localize_video"],
    "votes": ["TrackVotes"],
})
