"""`vehloc-localize` on a rendered scene: a video with no vehicle gives empty records and a line saying so
(exit 0); a vehicle cut by the frame's edge is recorded as not localized, with the reason; a calibration of
another image size and an ONNX file that is no vehloc classifier are each refused in one line, before any
frame is read."""

from __future__ import annotations

import json
from pathlib import Path

import onnx
import pandas as pd
import pytest
from bad_input import assert_one_error, run_cli, write_handmade_onnx
from onnx import TensorProto, helper

pytestmark = pytest.mark.slow  # renders a 230-frame scene and localizes it

EMPTY_FRAMES = 150  # the scene's empty road before the car comes (conf/scene/table2_site.yaml)


@pytest.fixture(scope="module")
def cut_scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The `cut_by_edge` scene, its calibration from its own markers, and a handmade classifier."""
    folder = tmp_path_factory.mktemp("cut_by_edge")
    scene = folder / "scene"
    rendered = run_cli("vehloc-scene", "scene=cut_by_edge", f"out={scene}", cwd=folder)
    assert rendered.returncode == 0, rendered.stderr[-2000:]
    calibrated = run_cli("vehloc-calibrate", f"site={scene / 'site.yaml'}", f"image={scene / 'video.avi'}",
                         f"hydra.run.dir={folder / 'calibration'}", cwd=folder)
    assert calibrated.returncode == 0, calibrated.stderr[-2000:]
    return {"video": scene / "video.avi", "calibration": folder / "calibration" / "calibration.json",
            "model": write_handmade_onnx(folder / "model.onnx", model_ids=(7, 9, 12)), "folder": folder}


def _localize(files: dict[str, Path], out: Path, *overrides: str):
    return run_cli("vehloc-localize", f"video={files['video']}", f"calibration={files['calibration']}",
                   f"model={files['model']}", f"hydra.run.dir={out}", "annotate=false", *overrides, cwd=files["folder"])


def test_a_video_with_no_vehicle_gives_empty_records_and_says_so(cut_scene: dict[str, Path], tmp_path: Path) -> None:
    result = _localize(cut_scene, tmp_path / "run", f"max_frames={EMPTY_FRAMES - 10}")
    assert result.returncode == 0, result.stderr[-2000:]
    assert "no vehicle stopped in" in result.stdout
    assert json.loads((tmp_path / "run" / "records.json").read_text()) == []


def test_a_vehicle_cut_by_the_frame_edge_is_not_localized_with_the_reason(cut_scene: dict[str, Path],
                                                                           tmp_path: Path) -> None:
    result = _localize(cut_scene, tmp_path / "run")
    assert result.returncode == 0, result.stderr[-2000:]
    records = pd.read_csv(tmp_path / "run" / "records.csv")
    assert len(records) == 1
    assert records.loc[0, "status"] == "not localized"
    assert records.loc[0, "reason_code"] == "touches_edge"
    assert "centre_x_mm" not in records.columns  # no invented position


def test_a_calibration_of_another_image_size_is_refused(cut_scene: dict[str, Path], tmp_path: Path) -> None:
    calibration = json.loads(cut_scene["calibration"].read_text())
    calibration["image_size_px"] = [640, 360]
    other = tmp_path / "calibration.json"
    other.write_text(json.dumps(calibration))
    result = _localize({**cut_scene, "calibration": other}, tmp_path / "run")
    assert_one_error(result, "vehloc-localize", "calibrates 640x360 px images", "video.avi is 1280x720 px")
    assert not (tmp_path / "run" / "records.csv").exists()


def _plain_onnx(path: Path) -> Path:
    """A valid ONNX graph (images -> their identity) without vehloc's metadata."""
    images = helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, 32, 32])
    output = helper.make_tensor_value_info("logits", TensorProto.FLOAT, [1, 3, 32, 32])
    graph = helper.make_graph([helper.make_node("Identity", ["images"], ["logits"])], "plain", [images], [output])
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), path)
    return path


@pytest.mark.parametrize("kind", ["random_bytes", "plain_onnx"])
def test_an_onnx_file_that_is_no_vehloc_model_is_refused(kind: str, cut_scene: dict[str, Path], tmp_path: Path) -> None:
    model = tmp_path / "model.onnx"
    if kind == "random_bytes":
        model.write_bytes(bytes(range(256)) * 8)
    else:
        _plain_onnx(model)
    result = _localize({**cut_scene, "model": model}, tmp_path / "run")
    assert_one_error(result, "vehloc-localize", str(model))
    assert not (tmp_path / "run" / "records.csv").exists()


def test_a_multirun_of_videos_through_submitits_local_executor_merges_them(cut_scene: dict[str, Path],
                                                                         tmp_path: Path) -> None:
    """`vehloc-localize -m hydra/launcher=submitit_local video=a,b,bad`: each video a submitit job; the two good
    ones end with their records, the bad one's folder with its reason; the multirun's folder holds one table of
    the videos (and their vehicles), and the command lists the failed job and exits 1."""
    videos = [tmp_path / "a.avi", tmp_path / "b.avi", tmp_path / "bad.avi"]
    for video in videos[:2]:
        video.write_bytes(cut_scene["video"].read_bytes())
    videos[2].write_text("not a video")
    sweep = tmp_path / "sweep"
    result = run_cli("vehloc-localize", "-m", "hydra/launcher=submitit_local", "hydra.launcher.timeout_min=10",
                     f"video={','.join(map(str, videos))}", f"calibration={cut_scene['calibration']}",
                     f"model={cut_scene['model']}", "annotate=false", f"hydra.sweep.dir={sweep}", cwd=tmp_path)
    assert result.returncode == 1, result.stderr[-3000:]
    for job in ("0", "1"):
        records = pd.read_csv(sweep / job / "records.csv")
        assert records["status"].tolist() == ["not localized"]  # the cut scene's one vehicle, as in a single run
    assert "bad.avi: not a readable video" in (sweep / "2" / "job_error.txt").read_text()
    assert (sweep / ".submitit").is_dir()  # the jobs went through submitit
    table = pd.read_csv(sweep / "multirun_videos.csv")
    assert table["video"].tolist() == list(map(str, videos))
    assert table["status"].tolist() == ["done", "done", "failed"]
    assert table["records"].tolist() == [1, 1, 0] and table["localized"].tolist() == [0, 0, 0]
    assert "not a readable video" in table.loc[2, "reason"]
    assert (sweep / "multirun_videos.md").is_file() and (sweep / "multirun_videos.png").stat().st_size > 1000
    assert "vehloc-localize: error: 1 of 3 jobs failed" in result.stderr and "Traceback" not in result.stderr


def test_a_video_cut_short_is_localized_as_far_as_it_decodes_and_says_where_it_stopped(
        cut_scene: dict[str, Path], tmp_path: Path) -> None:
    """A truncated file (its container still promising 230 frames): the frames decoded are localized, exit 0, and
    one warning line names the frame where decoding stopped (it used to pass for 'no vehicle stopped')."""
    data = cut_scene["video"].read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) * 3 // 4])
    result = _localize({**cut_scene, "video": cut}, tmp_path / "run")
    assert result.returncode == 0, result.stderr[-2000:]
    warnings = [line for line in result.stderr.splitlines() if line.startswith("vehloc-localize: warning:")]
    assert len(warnings) == 1 and f"{cut}: decoding stopped at frame " in warnings[0]
    assert "of the 230 its container promises" in warnings[0]
    assert (tmp_path / "run" / "records.csv").is_file()


def test_a_truth_file_of_another_scene_is_refused(cut_scene: dict[str, Path], tmp_path: Path) -> None:
    """The scene's truth with another frame count (another rendering) was accepted and scored against this video's
    records; it is refused in one line before any frame is read."""
    truth = json.loads((cut_scene["video"].parent / "ground_truth.json").read_text())
    truth["frames"] = truth["frames"] + 100
    other = tmp_path / "ground_truth.json"
    other.write_text(json.dumps(truth))
    result = _localize(cut_scene, tmp_path / "run", f"truth={other}")
    assert_one_error(result, "vehloc-localize", f"truth {other}: is of a scene of 1280x720 px and",
                     f"the video {cut_scene['video']} has 1280x720 px and")
    assert not (tmp_path / "run" / "records.csv").exists()


def test_a_second_run_into_the_same_folder_replaces_the_first_runs_outputs_only(cut_scene: dict[str, Path],
                                                                               tmp_path: Path) -> None:
    """Rerunning into an old run folder left the old Table 2 beside the new records; the run folder's manifest
    (`outputs.json`) names what a run wrote, and the next run removes exactly that before writing its own."""
    run = tmp_path / "run"
    first = _localize(cut_scene, run, f"truth={cut_scene['video'].parent / 'ground_truth.json'}")
    assert first.returncode == 0, first.stderr[-2000:]
    assert (run / "table2.md").is_file() and "table2.md" in json.loads((run / "outputs.json").read_text())["files"]
    mine = run / "my_notes.txt"
    mine.write_text("a user's own file")
    second = _localize(cut_scene, run, f"max_frames={EMPTY_FRAMES - 10}")
    assert second.returncode == 0, second.stderr[-2000:]
    assert not (run / "table2.md").exists() and not (run / "table2.csv").exists()
    assert json.loads((run / "records.json").read_text()) == [] and mine.read_text() == "a user's own file"
    written = json.loads((run / "outputs.json").read_text())["files"]
    assert {"records.csv", "records.json"} <= set(written) and not {"table2.md", "my_notes.txt"} & set(written)
