"""One video through the localizer and its files: the records (CSV + JSON), a picture of each localized
vehicle, every vehicle's path and speed (`speed.enabled`), and the paper's Table 2 when the scene's truth is given.
What `vehloc-localize` and `vehloc-demo` run."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
from tqdm import tqdm

from vehloc.atomic import write_image, write_text
from vehloc.geometry.pipeline.drawing import METHOD_COLOURS_BGR, draw_cuboid, write_birds_eye
from vehloc.geometry.pipeline.evaluation import table2_rows, write_case_figures, write_table2
from vehloc.geometry.pipeline.localize import Localizer, Status, VehicleRecord
from vehloc.geometry.pipeline.speed_files import write_speed_files
from vehloc.geometry.pipeline.model_choice import choose_models
from vehloc.geometry.pipeline.stitching import stitch
from vehloc.geometry.pipeline.unknown_vehicles import apart_from_known
from vehloc.geometry.pipeline.track_speed import TrackSpeeds, VehicleSpeed, along_traffic, assign_lanes
from vehloc.geometry.truth import SceneTruth
from vehloc.geometry.pipeline.video import VideoFrames

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class VideoLocalization:
    """The records of one video, its vehicles' speeds and the files written for it (`table2` when truth was given;
    `speeds` says what the speed files hold; `early_end`, when the video's decoding stopped short of what its
    container promises, says where: the records cover the frames decoded)."""

    records: tuple[VehicleRecord, ...]
    frames: int
    out_dir: Path
    table2: pd.DataFrame | None
    vehicles: tuple[VehicleSpeed, ...] = ()
    speeds: str = ""
    early_end: str | None = None

    @property
    def localized(self) -> int:
        return sum(r.status == Status.LOCALIZED for r in self.records)


def records_json(records: list[VehicleRecord]) -> str:
    return json.dumps([{**row} for record in records for row in record.rows()], indent=1, default=float)


def annotate(frame_bgr: np.ndarray, record: VehicleRecord, localizer: Localizer, out_dir: Path) -> list[Path]:
    """The frame with the estimated boxes drawn in, and the bird's-eye view of the estimates."""
    image = frame_bgr.copy()
    height_mm = record.dims_mm[2] if record.dims_mm else 1500.0
    for estimate in record.estimates:
        draw_cuboid(image, localizer.calibration.camera, estimate.box, height_mm, METHOD_COLOURS_BGR[estimate.method])
    cv2.rectangle(image, (record.box_px.x0, record.box_px.y0), (record.box_px.x1 - 1, record.box_px.y1 - 1), (200, 200, 200), 1)
    stem = f"track{record.track_id}_frame{record.frame}"
    title = f"track {record.track_id}, frame {record.frame}: {record.make} {record.model} ({record.probability:.2f})"
    return [write_image(out_dir / f"{stem}.png", image),
            write_birds_eye(out_dir / f"{stem}_birds_eye.png", {e.method: e.box for e in record.estimates}, title)]


def localize_video(localizer: Localizer, video: str | Path, out_dir: Path, truth: SceneTruth | None = None,
                   max_frames: int | None = None, pictures: bool = True, progress: bool = True,
                   fps: float | None = None) -> VideoLocalization:
    """Run `localizer` over `video` (its first `max_frames` frames) and write the records into `out_dir`; a
    picture per localized vehicle with `pictures`; Table 2 and its bird's-eye figures with `truth`. The speeds are
    at `fps` frames a second where given (a video whose container states another rate than it was filmed at), else
    at the container's rate."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    video_frames = VideoFrames(video)
    info = video_frames.info
    if fps is not None:
        info = replace(info, fps=fps)
    localizer.calibration.check_image_size(info.width_px, info.height_px, str(video))
    out_dir.mkdir(parents=True, exist_ok=True)
    total = video_frames.frames_to_read(max_frames)
    records: list[VehicleRecord] = []
    vehicles: list[VehicleSpeed] = []
    speeds = TrackSpeeds(localizer.classifier, localizer.calibration, localizer.speed_params, info.fps,
                         localizer.params.motion_jitter_px, 1.0 / localizer.extractor.params.scale)
    frames = 0
    for frame_index, frame in enumerate(tqdm(video_frames, total=total, desc="frames", unit="frame",
                                             disable=not progress)):
        if total is not None and frame_index >= total:
            break
        frames += 1
        for record in localizer.process(frame_index, frame):
            records.append(record)
            if pictures and record.status == Status.LOCALIZED:
                annotate(frame, record, localizer, out_dir)
        if localizer.speed_params.enabled:
            vehicles.extend(speeds.measure(track) for track in localizer.removed)
    if localizer.speed_params.enabled:
        vehicles.extend(speeds.measure(track) for track in localizer.finish())
    rows = [row for record in records for row in record.rows()]
    write_text(out_dir / "records.csv", pd.DataFrame(rows).to_csv(index=False, float_format="%.2f"))
    write_text(out_dir / "records.json", records_json(records))
    summary = ""
    if localizer.speed_params.enabled:
        vehicles = choose_models(sorted(vehicles, key=lambda v: v.track_id), localizer.speed_params)
        vehicles = stitch(vehicles, localizer.speed_params.stitch, speeds.refit, speeds.at_centre)
        vehicles = along_traffic(vehicles, localizer.speed_params)
        vehicles = apart_from_known(vehicles, localizer.speed_params, localizer.calibration.road_to_image)
        vehicles = assign_lanes(vehicles, localizer.speed_params)
        summary = write_speed_files(vehicles, localizer.calibration, out_dir, str(video), info.fps, pictures)
    table = None
    if truth is not None:
        table = pd.DataFrame(table2_rows(truth, records))
        write_table2(table, out_dir, f"Table 2: {truth.name}")
        write_case_figures(truth, records, out_dir)
    return VideoLocalization(tuple(records), frames, out_dir, table, tuple(vehicles), summary, video_frames.early_end)
