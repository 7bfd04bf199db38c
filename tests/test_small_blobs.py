"""A video whose frames carry blobs no classifier can take (an on-screen clock, a thin caption bar, specks) is
localized to its end: each such blob is a record saying why it was not localized, never the end of the run."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from bad_input import write_handmade_onnx

from vehloc.geometry.outcome import ReasonCode
from vehloc.geometry.pipeline.localize import Localizer, Status
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.infer.classifier import VehicleClassifier
from vehloc.synth.scene import CameraSpec

CAMERA = CameraSpec((0.0, -6000.0, 6500.0), (0.0, 20000.0, 0.0), 250.0, 320, 240, 0.0).camera()
HISTORY_FRAMES = 20


def frame_with_overlays(road_bgr: np.ndarray, index: int, rng: np.random.Generator) -> np.ndarray:
    """The road under fresh noise and, after the background's history, a ticking clock (text 7 px tall), a caption
    bar 60 x 6 px that blinks and specks of 1 to 3 px."""
    frame = np.clip(road_bgr + rng.normal(0.0, 2.0, road_bgr.shape), 0, 255).astype(np.uint8)
    if index < HISTORY_FRAMES:
        return frame
    cv2.putText(frame, f"12:00:{index % 60:02d}", (4, 12), cv2.FONT_HERSHEY_PLAIN, 0.7, (255, 255, 255), 1)
    if index % 4 < 2:
        frame[220:226, 200:260] = 250
    for k in range(1, 4):
        frame[100 + 20 * k:100 + 20 * k + k, 40 * k:40 * k + k] = 0
    return frame


def test_blobs_too_small_to_classify_are_records_and_the_run_goes_on(tmp_path: Path):
    """Every frame is processed by a real ONNX classifier's pipeline; the caption bar (6 px tall, under the
    classifier's 8) is a record not localized with the reason; the clock and the specks are too
    small to be vehicle blobs at all; nothing is localized (there is no vehicle)."""
    rng = np.random.default_rng(0)
    road = np.clip(rng.normal(110.0, 12.0, (240, 320, 3)), 0, 255)
    calibration = CameraCalibration(CAMERA.road_to_image(), (320, 240), CAMERA, 0.5, "test camera")
    classifier = VehicleClassifier.from_onnx(write_handmade_onnx(tmp_path / "model.onnx"))
    settings = LocalizeSettings.compose(["pipeline.every_frame=true", "roi.scale=1.0", "roi.close_kernel_px=5",
                                         f"roi.history_frames={HISTORY_FRAMES}"])
    localizer = Localizer(classifier, calibration, settings)
    records = [record for index in range(40)  # every frame: before the fix the caption bar raised ImageInputError
               for record in localizer.process(index, frame_with_overlays(road, index, rng))]
    too_small = [r for r in records if r.reason_code == ReasonCode.TOO_SMALL_TO_CLASSIFY]
    assert too_small and all(r.status == Status.NOT_LOCALIZED and min(r.box_px.width_px, r.box_px.height_px) < 8
                             for r in too_small)
    assert any(r.box_px.y0 >= 215 and r.box_px.width_px >= 50 for r in too_small)  # the caption bar
    assert not [r for r in records if r.status == Status.LOCALIZED]
