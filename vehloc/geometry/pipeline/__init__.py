"""The localization pipeline: the geometry of `vehloc.geometry` run over a video with the classifier. The
frames' vehicle boxes are followed by the tracker (one `VehicleTrack` per vehicle, removed when lost), each
track's crops are voted on once, the stopped (or every) vehicle is placed and fitted, and each outcome is a
`VehicleRecord`; around it the video reading, the records' files and pictures, Table 2 against a scene's truth,
the site calibration's files and the `vehloc-localize` and `vehloc-calibrate` CLIs. The names below are its
API."""

from vehloc.geometry.pipeline.evaluation import table2_rows, write_table2
from vehloc.geometry.pipeline.localize import (
    Estimate,
    Localizer,
    Status,
    VehicleRecord,
    localize_frames,
)
from vehloc.geometry.pipeline.settings import LocalizeSettings, PipelineParams
from vehloc.geometry.pipeline.site_calibration import SiteCalibration, calibrate_site, write_calibration_files
from vehloc.geometry.pipeline.table2 import PoseError, pose_error
from vehloc.geometry.pipeline.timing import StageClock
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker, TrackerParams, TrackerUpdate, TrackState, VehicleTrack
from vehloc.geometry.pipeline.travel import Travel, track_travel
from vehloc.geometry.pipeline.video import MediaError, VideoInfo, iter_frames, read_still, video_info
from vehloc.geometry.pipeline.video_localization import VideoLocalization, localize_video
from vehloc.geometry.pipeline.votes import TrackVotes

__all__ = [
    "Estimate", "LocalizeSettings", "Localizer", "MediaError", "PipelineParams", "PoseError",
    "SiteCalibration", "StageClock", "Status", "StoppedVehicleTracker", "TrackState", "TrackVotes", "TrackerParams",
    "TrackerUpdate", "Travel", "VehicleRecord", "VehicleTrack", "VideoInfo", "VideoLocalization", "calibrate_site",
    "iter_frames", "localize_frames", "localize_video", "pose_error", "read_still", "table2_rows", "track_travel",
    "video_info", "write_calibration_files", "write_table2",
]
