"""`vehloc-localize video=... calibration=... model=... [truth=...]`: localize the vehicles of a video and
write the records (CSV + JSON), a picture of each localized vehicle, and the paper's Table 2 when the
scene's ground truth is given."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import hydra
import pandas as pd
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from vehloc.atomic import write_image, write_text
from vehloc.config import build_params, config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.drawing import METHOD_COLOURS_BGR, draw_cuboid, write_birds_eye
from vehloc.geometry.evaluation import table2_rows, write_case_figures, write_table2
from vehloc.geometry.keypoints import DetectorParams
from vehloc.geometry.localize import LOCALIZED, Localizer, PipelineParams, VehicleRecord
from vehloc.geometry.model_fit import FitParams
from vehloc.geometry.roi import RoiParams, TrackerParams
from vehloc.geometry.site_calibration import read_calibration
from vehloc.geometry.truth import read_scene_truth
from vehloc.geometry.video import iter_frames, video_info
from vehloc.infer.classifier import VehicleClassifier


def _params(cls: type, cfg: DictConfig, key: str):
    return build_params(cls, OmegaConf.to_container(cfg[key], resolve=True), key)


def records_json(records: list[VehicleRecord]) -> str:
    return json.dumps([{**row} for record in records for row in record.rows()], indent=1, default=float)


def annotate(frame_bgr, record: VehicleRecord, localizer: Localizer, out_dir: Path) -> list[Path]:
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


@hydra.main(version_base="1.3", config_path=str(config_dir() / "localize"), config_name="localize")
@exit_on_error("vehloc-localize")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    params = _params(PipelineParams, cfg, "pipeline")
    roi, tracker, fit = _params(RoiParams, cfg, "roi"), _params(TrackerParams, cfg, "tracker"), _params(FitParams, cfg, "fit")
    detectors = DetectorParams.from_mapping(
        {group: OmegaConf.to_container(cfg[group], resolve=True) for group in ("footprint", "plate", "wheels")})
    calibration = read_calibration(cfg.calibration)
    classifier = VehicleClassifier.from_onnx(cfg.model)
    truth = read_scene_truth(cfg.truth) if cfg.truth else None
    info = video_info(cfg.video)
    calibration.check_image_size(info.width_px, info.height_px, str(cfg.video))
    localizer = Localizer(classifier, calibration, params, roi, tracker, detectors, fit)

    records: list[VehicleRecord] = []
    frames = iter_frames(cfg.video)
    total = info.frame_count if cfg.max_frames is None else min(info.frame_count, cfg.max_frames)
    for frame_index, frame in enumerate(tqdm(frames, total=total, desc="frames", unit="frame")):
        if cfg.max_frames is not None and frame_index >= cfg.max_frames:
            break
        for record in localizer.process(frame_index, frame):
            records.append(record)
            if cfg.annotate and record.status == LOCALIZED:
                annotate(frame, record, localizer, out_dir)

    rows = [row for record in records for row in record.rows()]
    write_text(out_dir / "records.csv", pd.DataFrame(rows).to_csv(index=False, float_format="%.2f"))
    write_text(out_dir / "records.json", records_json(records))
    localized = sum(r.status == LOCALIZED for r in records)
    if not records:
        print(f"no vehicle {'in view' if params.every_frame else 'stopped'} in {cfg.video}: empty records in {out_dir}")
    else:
        print(f"{len(records)} record(s), {localized} localized: {out_dir / 'records.csv'}")
    if truth is not None:
        table = pd.DataFrame(table2_rows(truth, records))
        write_table2(table, out_dir, f"Table 2: {truth.name}")
        write_case_figures(truth, records, out_dir)
        print(f"Table 2 against {cfg.truth}: {out_dir / 'table2.md'}")


if __name__ == "__main__":
    main()
