"""Bad input to the torch-free console scripts (`vehloc-data`, `vehloc-predict`, `vehloc-scene`,
`vehloc-calibrate`), as a new user gives it: each kind ends with one line `<prog>: error: ...` naming the file
or value and what is wrong, a non-zero exit code, and an earlier output left byte for byte as it was."""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from bad_input import (
    assert_one_error,
    cli_env,
    leftovers,
    read_only_supported,
    run_cli,
    run_cli_read_only,
    snapshot,
    write_handmade_onnx,
)
from conftest import write_tiny_compcars
from scene_configs import scene_spec

from vehloc.atomic import write_text
from vehloc.geometry.site import site_yaml
from vehloc.synth.road import render_road
from vehloc.synth.scene_site import scene_site

LATIN1_SPECS = ("model_id,make,model,length_mm,width_mm,height_mm,wheelbase_mm\n"
                "11,Citroën,Alpha,4500,1800,1450,2700\n12,MakeOne,Beta,4600,1850,1470,\n"
                "25,MakeTwo,Gamma,4000,1700,1600,2500\n").encode("latin-1")
RANDOM_BYTES = np.random.default_rng(7).integers(0, 256, 400, dtype=np.uint8).tobytes()


def _truncate(path: Path, keep: float = 0.6) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])


def _big_jpeg(path: Path) -> None:
    """A 200x150 JPEG, large enough that a truncated copy still decodes to a grey-filled image."""
    rng = np.random.default_rng(1)
    image = cv2.GaussianBlur(rng.integers(0, 255, (150, 200, 3), dtype=np.uint8), (0, 0), 2)
    cv2.imwrite(str(path), image)


def _corrupt_jpeg(path: Path) -> None:
    """A JPEG cut short but ending with the end-of-image marker: only the decoder's warning tells."""
    _big_jpeg(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2] + b"\xff\xd9")


IMAGE = "image/1/11/2015/img0.jpg"
LABEL = "label/1/11/2015/img0.txt"
SPLIT = "train_test_split/classification/train.txt"

# --- vehloc-data check -------------------------------------------------------------------------------------

CHECK_CASES: dict[str, tuple[Callable[[Path], object], list[str], tuple[str, ...]]] = {
    "split_list_binary": (lambda r: (r / SPLIT).write_bytes(b"\xff\xfe\x00" + RANDOM_BYTES), [],
                          (SPLIT, "not UTF-8 text: byte 0xff at offset 0")),
    "specs_latin1": (lambda r: (r / "specs.csv").write_bytes(LATIN1_SPECS), [],
                     ("specs.csv", "not UTF-8 text", "byte 0xeb at offset 70 (line 2)")),
    "attributes_binary": (lambda r: (r / "misc/attributes.txt").write_bytes(RANDOM_BYTES), [],
                          ("misc/attributes.txt", "not UTF-8 text")),
    "attributes_nul_bytes": (lambda r: (r / "misc/attributes.txt").write_bytes(b"model_id\x00\x00\x01\x02"), [],
                             ("misc/attributes.txt", "a binary file, not text (NUL byte at offset 8)")),
    "label_latin1": (lambda r: (r / LABEL).write_bytes("4\n1\n3 2 38 29 é\n".encode("latin-1")), [],
                     (LABEL, "not UTF-8 text", "(a label file)")),
    "truncated_jpeg": (lambda r: (_big_jpeg(r / IMAGE), _truncate(r / IMAGE)), ["--images"],
                       (IMAGE, "truncated JPEG: it does not end with the end-of-image marker FF D9")),
    "corrupt_jpeg": (lambda r: _corrupt_jpeg(r / IMAGE), ["--images"],
                     (IMAGE, "corrupt image data (the decoder says: Corrupt JPEG data")),
    "image_not_an_image": (lambda r: (r / IMAGE).write_text("hello"), ["--images"], (IMAGE, "not a readable image")),
}


@pytest.mark.parametrize("kind", CHECK_CASES)
def test_check_names_the_bad_file(kind: str, tiny_root: Path) -> None:
    """`vehloc-data check` lists every problem on stderr (one here), never a traceback, exit 1."""
    breaking, extra, fragments = CHECK_CASES[kind]
    breaking(tiny_root)
    result = run_cli("vehloc-data", "check", tiny_root, *extra)
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines[0] == "1 problem(s):" and len(lines) == 2, result.stderr
    for fragment in fragments:
        assert fragment in lines[1], lines[1]


def test_check_accepts_a_specs_table_with_a_byte_order_mark(tiny_root: Path) -> None:
    specs = tiny_root / "specs.csv"
    specs.write_bytes(b"\xef\xbb\xbf" + specs.read_bytes())
    result = run_cli("vehloc-data", "check", tiny_root, "--images")
    assert result.returncode == 0 and "covers all 3 classes" in result.stdout, result.stderr


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["check", "{root}", "--specs", "{tmp}/none.csv"], ["--specs", "none.csv: no such file"]),
        (["check", "{tmp}/root_as_file.txt"], ["root_as_file.txt: data root does not exist or is not a folder"]),
    ],
    ids=["specs_missing", "root_is_a_file"],
)
def test_check_arguments(args: list[str], fragments: list[str], tiny_root: Path, tmp_path: Path) -> None:
    (tmp_path / "root_as_file.txt").write_text("x")
    result = run_cli("vehloc-data", *(a.format(root=tiny_root, tmp=tmp_path) for a in args))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert all(f in result.stderr for f in fragments), result.stderr


# --- vehloc-data make-demo and contact-sheet ---------------------------------------------------------------------

@pytest.mark.parametrize(
    ("args", "fragments", "code"),
    [
        (["make-demo", "{tmp}/demo", "--per-model", "1"], ["--per-model: expected an integer >= 2, got 1"], 2),
        (["make-demo", "{tmp}/demo", "--per-model", "abc"], ["--per-model: expected an integer, got 'abc'"], 2),
        (["make-demo", "{tmp}/demo", "--seed", "-1"], ["--seed: expected an integer from 0 to 4294967295, got -1"], 2),
        (["make-demo", "{tmp}/demo", "--workers", "0"], ["--workers: expected an integer >= 1, got 0"], 2),
        (["make-demo", "{tmp}/demo", "--views", "sky"], ["--views: invalid choice: 'sky'"], 2),
        (["make-demo", "{tmp}/file.txt", "--per-model", "2"], ["file.txt: is a file, not a folder"], 1),
        (["make-demo", "{tmp}/foreign", "--per-model", "2"], ["foreign: not empty and not a vehloc demo set"], 1),
        (["contact-sheet", "{root}", "{tmp}"], ["contact sheet", "is a folder; give a file name"], 1),
        (["contact-sheet", "{root}", "{tmp}/sheet.txt"], ["sheet.txt: OpenCV cannot write '.txt' images"], 1),
        (["contact-sheet", "{root}", "{tmp}/file.txt/sheet.png"], ["file.txt is a file, not a folder"], 1),
        (["contact-sheet", "{root}", "{tmp}/s.png", "--per-model", "0"], ["--per-model: expected an integer from 1 to 100, got 0"], 2),
        (["contact-sheet", "{root}", "{tmp}/s.png", "--per-model", "-3"], ["--per-model: expected an integer from 1 to 100, got -3"], 2),
        (["contact-sheet", "{tmp}/none", "{tmp}/s.png"], ["none: 1 problem(s) in CompCars data"], 1),
        (["make-dmeo", "{tmp}/demo"], ["invalid choice: 'make-dmeo'"], 2),
    ],
    ids=["per_model_1", "per_model_text", "seed_negative", "workers_0", "views", "out_is_a_file", "out_is_foreign",
         "sheet_is_a_folder", "sheet_suffix", "sheet_parent_is_a_file", "sheet_per_model_0", "sheet_per_model_negative",
         "sheet_root_missing", "unknown_command"],
)
def test_data_arguments(args: list[str], fragments: list[str], code: int, tiny_root: Path, tmp_path: Path) -> None:
    (tmp_path / "file.txt").write_text("keep me")
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "notes.txt").write_text("keep me")
    before = snapshot(tmp_path)
    result = run_cli("vehloc-data", *(a.format(root=tiny_root, tmp=tmp_path) for a in args))
    if code == 1 and "problem(s)" in fragments[0]:  # a data-set error lists its problems under the line
        assert result.returncode == 1 and result.stderr.startswith("vehloc-data: error:") and "Traceback" not in result.stderr
    else:
        assert_one_error(result, "vehloc-data", *fragments, code=code)
    assert snapshot(tmp_path) == before and not (tmp_path / "demo").exists()


def test_make_demo_replaces_its_own_set_whole_and_cleans_a_killed_run(tmp_path: Path) -> None:
    """A re-run replaces an earlier demo set; the temporary folder a killed run left beside it is removed, and
    a partial set is never what the folder holds."""
    out = tmp_path / "demo"
    assert run_cli("vehloc-data", "make-demo", out, "--per-model", "2", "--workers", "1").returncode == 0
    stale = tmp_path / ".demo.999999.tmp"  # a run killed with SIGKILL (no such process)
    (stale / "image").mkdir(parents=True)
    first = snapshot(out)
    result = run_cli("vehloc-data", "make-demo", out, "--per-model", "2", "--workers", "1", "--seed", "1")
    assert result.returncode == 0, result.stderr
    second = snapshot(out)
    assert second.keys() == first.keys() and second != first
    assert not leftovers(tmp_path)


# --- vehloc-predict -------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def model_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("models")
    random_bytes = folder / "random.onnx"
    random_bytes.write_bytes(RANDOM_BYTES)
    return {
        "good": write_handmade_onnx(folder / "good.onnx"),
        "input_size": write_handmade_onnx(folder / "input_size.onnx", metadata_changes={"preprocessing.input_size_px": 64,
                                                                                       "preprocessing.resize_px": 64}),
        "class_count": write_handmade_onnx(folder / "class_count.onnx", output_width=5),
        "negative_length": write_handmade_onnx(folder / "negative_length.onnx", metadata_changes={"classes.1.length_mm": -4000}),
        "nan_width": write_handmade_onnx(folder / "nan_width.onnx", metadata_changes={"classes.0.width_mm": float("nan")}),
        "input_name": write_handmade_onnx(folder / "input_name.onnx", metadata_changes={"input_name": "pixels"}),
        "top_k": write_handmade_onnx(folder / "top_k.onnx", metadata_changes={"expected_top_k": 0}),
        "random": random_bytes,
    }


PREDICT_CASES = {
    "top_k_0": (["--top-k", "0", "{image}"], ["--top-k: expected an integer >= 1, got 0"], 2),
    "top_k_negative": (["--top-k", "-2", "{image}"], ["--top-k: expected an integer >= 1, got -2"], 2),
    "top_k_text": (["--top-k", "five", "{image}"], ["--top-k: expected an integer, got 'five'"], 2),
    "csv_is_a_folder": (["--csv", "{tmp}", "{image}"], ["--csv", "is a folder; give a file name"], 1),
    "csv_parent_is_a_file": (["--csv", "{tmp}/keep.csv/p.csv", "{image}"], ["keep.csv is a file, not a folder"], 1),
    "csv_is_the_model": (["--csv", "{model:good}", "{image}"], ["--csv", "good.onnx: is an input this run reads"], 1),
    "csv_is_an_image": (["--csv", "{image}", "{image}"], ["--csv", "is an input this run reads"], 1),
    "image_missing": (["{tmp}/none.jpg"], ["none.jpg: image does not exist"], 1),
    "image_is_a_folder": (["{tmp}"], ["is a folder"], 1),
    "image_truncated": (["{truncated}"], ["truncated.jpg: truncated JPEG"], 1),
    "image_not_an_image": (["--csv", "{tmp}/out.csv", "{tmp}/keep.csv"], ["keep.csv: not a readable image"], 1),
    "label_latin1": (["--compcars-labels", "{latin1_label_image}"], ["img1.txt: not UTF-8 text"], 1),
    "label_malformed": (["--compcars-labels", "{bad_label_image}"], ["img2.txt: malformed label: line 3"], 1),
    "model_missing": (["--model", "{tmp}/none.onnx", "{image}"], ["none.onnx: model file does not exist"], 1),
    "model_is_a_folder": (["--model", "{tmp}", "{image}"], ["model file does not exist (it is a folder)"], 1),
    "model_random_bytes": (["--model", "{model:random}", "{image}"], ["random.onnx: not a loadable ONNX model"], 1),
    "model_input_size": (["--model", "{model:input_size}", "{image}"],
                         ["input_size.onnx: the graph takes input shape (N, 3, 32, 32), its metadata says (N, 3, 64, 64)"], 1),
    "model_class_count": (["--model", "{model:class_count}", "{image}"],
                          ["class_count.onnx: output 'logits' has shape (N, 5), but the metadata lists 3 classes"], 1),
    "model_negative_length": (["--model", "{model:negative_length}", "{image}"],
                              ["negative_length.onnx: class 12 has dimensions [-4000", "finite and positive"], 1),
    "model_nan_width": (["--model", "{model:nan_width}", "{image}"], ["nan_width.onnx: class 11 has dimensions"], 1),
    "model_input_name": (["--model", "{model:input_name}", "{image}"],
                         ["input_name.onnx: the graph's inputs ['images'] are not the one input 'pixels'"], 1),
    "model_expected_top_k": (["--model", "{model:top_k}", "{image}"], ["top_k.onnx: expected_top_k 0"], 1),
}


@pytest.mark.parametrize("kind", PREDICT_CASES)
def test_predict_bad_input(kind: str, model_files: dict[str, Path], tiny_root: Path, tmp_path: Path) -> None:
    args, fragments, code = PREDICT_CASES[kind]
    keep = tmp_path / "keep.csv"
    keep.write_text("an earlier table\n")
    truncated = tmp_path / "truncated.jpg"
    _big_jpeg(truncated)
    _truncate(truncated)
    (tiny_root / "label/1/11/2015/img1.txt").write_bytes("4\n1\n3 2 38 29\né\n".encode("latin-1"))
    (tiny_root / "label/1/11/2015/img2.txt").write_text("4\n1\n3 2 38\n")
    values = {"image": tiny_root / IMAGE, "tmp": tmp_path, "truncated": truncated,
              "latin1_label_image": tiny_root / "image/1/11/2015/img1.jpg",
              "bad_label_image": tiny_root / "image/1/11/2015/img2.jpg"}
    argv = []
    for arg in args:
        if arg.startswith("{model:"):
            argv.append(str(model_files[arg[7:-1]]))
        else:
            argv.append(arg.format(**values))
    if "--model" not in argv:
        argv = ["--model", str(model_files["good"]), *argv]
    before = snapshot(tmp_path)
    result = run_cli("vehloc-predict", *argv, "--csv", keep) if "--csv" not in argv else run_cli("vehloc-predict", *argv)
    assert_one_error(result, "vehloc-predict", *fragments, code=code)
    assert snapshot(tmp_path) == before  # the earlier --csv table is untouched
    assert result.stdout == ""  # nothing was classified


def test_predict_with_the_handmade_model_works(model_files: dict[str, Path], tiny_root: Path, tmp_path: Path) -> None:
    """The stand-in model itself is sound: the bad-input runs above fail on their one fault."""
    csv = tmp_path / "p.csv"
    result = run_cli("vehloc-predict", "--model", model_files["good"], "--top-k", "9", "--csv", csv, tiny_root / IMAGE)
    assert result.returncode == 0, result.stderr
    assert len(csv.read_text().splitlines()) == 1 + 3 and not leftovers(tmp_path)


def test_predict_csv_on_a_read_only_file_system(model_files: dict[str, Path], tiny_root: Path, tmp_path: Path) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    (folder / "p.csv").write_text("earlier\n")
    if not read_only_supported(folder):
        pytest.skip("cannot mount a read-only file system here")
    result = run_cli_read_only(folder, "vehloc-predict", "--model", model_files["good"], "--csv", folder / "p.csv",
                               tiny_root / IMAGE)
    assert_one_error(result, "vehloc-predict", "--csv", "p.csv: cannot write in", "Read-only file system")
    assert (folder / "p.csv").read_text() == "earlier\n" and result.stdout == ""


# --- vehloc-scene -------------------------------------------------------------------------------------------

SHORT = ["scene.empty_frames=1", "scene.drive_frames=2", "scene.stopped_frames=1"]
SCENE_CASES = {
    "model_id": (["scene.cars.0.model_id=999"], ["scene.cars[0]: model_id 999 is not a catalog model (1 to 12)"]),
    "target_text": (["scene.cars.0.target_x_mm=abc"], ["scene.cars[0].target_x_mm: expected a finite number, got 'abc'"]),
    "stops_text": (["scene.cars.0.stops=maybe"], ["scene.cars[0].stops: expected true or false, got 'maybe'"]),
    "car_out_of_view": (["scene.cars.0.target_y_mm=-50000"], ["scene.cars[0]: at its target pose (194, -50000) mm the car is not in the camera's view"]),
    "fps_0": (["scene.fps=0"], ["scene.fps: must be in (0, 1000], got 0.0"]),
    "frames_negative": (["scene.empty_frames=-5"], ["scene.empty_frames: must be in [0, 100000], got -5"]),
    "focal_negative": (["scene.camera.focal_px=-5"], ["scene.camera.focal_px: must be > 0, got -5.0"]),
    "width_0": (["scene.camera.width_px=0"], ["scene.camera.width_px: must be in [16, 8192], got 0"]),
    "lane_width_negative": (["scene.layout.lane_width_mm=-5"], ["scene.layout.lane_width_mm: must be > 0, got -5.0"]),
    "codec": (["scene.codec=h264"], ["scene: codec must be one of"]),
    "no_car": (["scene.cars=[]"], ["scene: cars: a scene needs at least one car"]),
    "noise_text": (["site_click_noise_px=abc"], ["site_click_noise_px: expected a number >= 0, got 'abc'"]),
    "noise_negative": (["site_click_noise_px=-1"], ["site_click_noise_px: expected a number >= 0, got -1"]),
    "unknown_setting": (["scene.speed=3"], ["Could not override 'scene.speed': Key 'speed' is not in struct (no such setting)"]),
    "unknown_scene": (["scene=nope"], ["In 'scene': Could not find 'scene/nope' (options: cut_by_edge"]),
    "override_syntax": (["scene.fps=[1"], ["no viable alternative at input '[1'"]),
    "car_and_road_out_of_view": (["scene.camera.target_mm=[0,9000,20000]"], ["scene.cars[0]: at its target pose (194, 4060) mm the car is not in the camera's view"]),
    "no_site_possible": (["scene.layout.end_y_mm=-2000", "scene.layout.stop_line_y_mm=null"],
                         ["scene table2_close_0: the road has no marker with corners; no site file can be made"]),
}


@pytest.fixture(scope="module")
def earlier_scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small scene written by vehloc-scene, to be left as it is by every failed run into its folder."""
    out = tmp_path_factory.mktemp("scene") / "scene"
    result = run_cli("vehloc-scene", "scene=table2_close_0", f"out={out}", *SHORT)
    assert result.returncode == 0, result.stderr
    return out


@pytest.mark.parametrize("kind", SCENE_CASES)
def test_scene_bad_settings_leave_the_earlier_scene(kind: str, earlier_scene: Path) -> None:
    overrides, fragments = SCENE_CASES[kind]
    before = snapshot(earlier_scene)
    result = run_cli("vehloc-scene", "scene=table2_close_0", f"out={earlier_scene}", *SHORT, *overrides)
    assert_one_error(result, "vehloc-scene", *fragments)
    after = snapshot(earlier_scene)
    after.pop("scene_cli.log", None), before.pop("scene_cli.log", None)  # Hydra's own log of the run
    assert after == before and not leftovers(earlier_scene)


@pytest.mark.parametrize(
    ("out", "fragments"),
    [("{tmp}/file.txt", ["file.txt: exists and is not a folder"]), (None, ["out=... is required (it has no value)"])],
    ids=["out_is_a_file", "out_missing"],
)
def test_scene_output_folder(out: str | None, fragments: list[str], tmp_path: Path) -> None:
    (tmp_path / "file.txt").write_text("keep me")
    result = run_cli("vehloc-scene", *([f"out={out.format(tmp=tmp_path)}"] if out else []), *SHORT)
    assert_one_error(result, "vehloc-scene", *fragments)
    assert (tmp_path / "file.txt").read_text() == "keep me"


# --- vehloc-calibrate and site files --------------------------------------------------------------------------

MARKER = "  - id: a\n    corners_mm: {corners}\n"
GOOD_CORNERS = "[[0, 0], [150, 0], [150, 3000], [0, 3000]]"
GUESS = "initial_guess:\n  points:\n" + "".join(
    f"    - {{world_mm: [{x}, {y}], image_px: [{x / 10}, {y / 10}]}}\n" for x, y in [(0, 0), (150, 0), (150, 3000), (0, 3000)])
SITE_CASES = {
    "random_bytes": (RANDOM_BYTES, ["not UTF-8 text: byte 0x"]),
    "latin1": ("name: Straße\n".encode("latin-1"), ["not UTF-8 text: byte 0xdf at offset 10 (line 1)"]),
    "not_yaml": (b"markers: [\n  - {", ["not valid YAML"]),
    "nan_corner": (("markers:\n" + MARKER.format(corners="[[.nan, 0], [150, 0], [150, 3000], [0, 3000]]") + GUESS).encode(),
                   ["markers[0].corners_mm[0]: expected finite numbers"]),
    "two_corners": (("markers:\n" + MARKER.format(corners="[[0, 0], [150, 0]]") + GUESS).encode(),
                    ["markers[0].corners_mm: a marker has 4 corners, got 2"]),
    "identical_corners": (("markers:\n" + MARKER.format(corners="[[5, 5], [5, 5], [5, 5], [5, 5]]") + GUESS).encode(),
                          ["markers[0].corners_mm: two or more corners are the same point"]),
    "collinear_corners": (("markers:\n" + MARKER.format(corners="[[0, 0], [1, 0], [2, 0], [3, 0]]") + GUESS).encode(),
                          ["markers[0].corners_mm: the corners enclose no area"]),
    "text_corner": (("markers:\n" + MARKER.format(corners="[[a, 0], [150, 0], [150, 3000], [0, 3000]]") + GUESS).encode(),
                    ["markers[0].corners_mm[0]: expected two numbers"]),
    "negative_size": (("image_size_px: [-1280, 720]\nmarkers:\n" + MARKER.format(corners=GOOD_CORNERS) + GUESS).encode(),
                      ["image_size_px: expected [width, height], two positive integers, got [-1280, 720]"]),
    "fractional_size": (("image_size_px: [1280.5, 720]\nmarkers:\n" + MARKER.format(corners=GOOD_CORNERS) + GUESS).encode(),
                        ["image_size_px: expected [width, height], two positive integers"]),
    "stripe_width": (("markers:\n" + MARKER.format(corners=GOOD_CORNERS)
                      + "stripes:\n  - {from_mm: [0, 0], to_mm: [0, 9000], width_mm: -150}\n" + GUESS).encode(),
                     ["stripes[0].width_mm: expected a positive number, got -150"]),
    "homography_nan": (("markers:\n" + MARKER.format(corners=GOOD_CORNERS)
                        + "initial_guess:\n  homography: [[1, 0, 0], [0, .nan, 0], [0, 0, 1]]\n").encode(),
                       ["initial_guess.homography must be an invertible 3x3 matrix of finite numbers"]),
    "a_list": (b"- markers\n- initial_guess\n", ["expected a mapping with 'markers' and 'initial_guess'"]),
}


@pytest.fixture(scope="module")
def road_and_site(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("site")
    spec = scene_spec("table2_middle_0")
    cv2.imwrite(str(folder / "road.png"), render_road(spec.camera.camera(), spec.layout, np.random.default_rng(0)))
    write_text(folder / "site.yaml", site_yaml(scene_site(spec)))
    return folder / "road.png", folder / "site.yaml"


@pytest.fixture(scope="module")
def earlier_calibration(road_and_site: tuple[Path, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    image, site = road_and_site
    out = tmp_path_factory.mktemp("calibration")
    result = run_cli("vehloc-calibrate", f"site={site}", f"image={image}", f"hydra.run.dir={out}")
    assert result.returncode == 0, result.stderr
    return out


@pytest.mark.parametrize("kind", SITE_CASES)
def test_bad_site_files_are_named_when_read(kind: str, road_and_site: tuple[Path, Path], earlier_calibration: Path,
                                            tmp_path: Path) -> None:
    content, fragments = SITE_CASES[kind]
    site = tmp_path / "site.yaml"
    site.write_bytes(content)
    image, _ = road_and_site
    before = {k: v for k, v in snapshot(earlier_calibration).items() if not k.startswith(".hydra")}
    result = run_cli("vehloc-calibrate", f"site={site}", f"image={image}", f"hydra.run.dir={earlier_calibration}")
    assert_one_error(result, "vehloc-calibrate", f"{site}: ", *fragments)
    after = {k: v for k, v in snapshot(earlier_calibration).items() if not k.startswith(".hydra")}
    assert {k: v for k, v in after.items() if not k.endswith(".log")} == {k: v for k, v in before.items() if not k.endswith(".log")}


CALIBRATE_CASES = {
    "frame_index_negative": (["frame_index=-1"], ["frame_index: must be >= 0, got -1"]),
    "background_negative": (["background_frames=-1"], ["background_frames: must be in [0, 10000], got -1"]),
    "grid_step_0": (["grid_step_mm=0"], ["grid_step_mm: must be in [100, 100000], got 0.0"]),
    "grid_step_text": (["grid_step_mm=wide"], ["grid_step_mm: expected a finite number, got 'wide'"]),
    "mode": (["mode=magic"], ["mode: expected one of detect, guess, auto, got 'magic'"]),
    "detection_setting": (["detection.min_area_px=abc"], ["detection.min_area_px: expected"]),
    "site_missing_value": (["site=???"], ["site=PATH is required"]),
    "site_is_a_folder": (["site={tmp}"], ["site file does not exist (it is a folder)"]),
    "image_size_mismatch": (["site={small_site}"], ["small_site.yaml: image_size_px is 640x480", "road.png is 1280x720 px"]),
    "run_dir_is_a_file": (["hydra.run.dir={tmp}/file.txt"], ["file.txt: exists and is not a folder"]),
}


@pytest.mark.parametrize("kind", CALIBRATE_CASES)
def test_calibrate_bad_settings(kind: str, road_and_site: tuple[Path, Path], tmp_path: Path) -> None:
    image, site = road_and_site
    small_site = tmp_path / "small_site.yaml"
    small_site.write_text(site.read_text().replace("- 1280\n- 720", "- 640\n- 480"))
    assert small_site.read_text() != site.read_text()
    (tmp_path / "file.txt").write_text("keep me")
    overrides, fragments = CALIBRATE_CASES[kind]
    overrides = [o.format(tmp=tmp_path, small_site=small_site) for o in overrides]
    run_dir = [] if any(o.startswith("hydra.run.dir") for o in overrides) else [f"hydra.run.dir={tmp_path / 'out'}"]
    result = run_cli("vehloc-calibrate", f"site={site}", f"image={image}", *run_dir, *overrides)
    assert_one_error(result, "vehloc-calibrate", *fragments)
    assert not (tmp_path / "out" / "calibration.json").exists() and (tmp_path / "file.txt").read_text() == "keep me"


def test_tiny_root_fixture_is_clean(tmp_path: Path) -> None:
    root = write_tiny_compcars(tmp_path / "tiny")
    result = run_cli("vehloc-data", "check", root, "--images")
    assert result.returncode == 0 and "no problems found" in result.stdout, result.stderr
    shutil.rmtree(root)


# --- the scripts under experiments/ -----------------------------------------------------------------------------

SCRIPT_CASES = {
    "int8_vs_fp32_missing_model": ("experiments/benchmarks/int8_vs_fp32.py",
                                   ["--fp32", "{tmp}/none.onnx", "--int8", "{tmp}/none.int8.onnx", "--out", "{tmp}/out"],
                                   "none.onnx: model file does not exist"),
    "localize_stages_missing_model": ("experiments/benchmarks/localize_stages.py",
                                      ["--video", "{tmp}/v.avi", "--calibration", "{tmp}/c.json",
                                       "--model", "{tmp}/none.onnx", "--out", "{tmp}/out"],
                                      "none.onnx: model file does not exist"),
    "highway_hand_check_missing_calibration": ("experiments/real_video/highway_hand_check.py",
                                               ["--calibration", "{tmp}/none.json", "--localized", "{tmp}/run",
                                                "--out", "{tmp}/out"],
                                               "none.json: calibration file does not exist"),
    "speed_missing_model": ("experiments/speed/run.py", ["--model", "{tmp}/none.onnx", "--out", "{tmp}/out"],
                            "--model {tmp}/none.onnx: no such file"),
    "speed_seeds_backwards": ("experiments/speed/run.py", ["--model", "{tmp}/none.onnx", "--out", "{tmp}/out", "--cases",
                                                           "traffic_720p:5-3"],
                              "--cases 'traffic_720p:5-3': the last seed is before the first"),
    "auto_calibration_bad_setting": ("experiments/auto_calibration/run.py",
                                     ["--model", "{tmp}/none.onnx", "--out", "{tmp}/out", "--set", "tracker.min_iou=2"],
                                     "tracker.min_iou: must be in [0, 1], got 2.0"),
    "compare_missing_run": ("experiments/localization_benchmark/compare.py",
                            ["{tmp}/before", "{tmp}/after", "--out", "{tmp}/out"],
                            "{tmp}/before: no such file (a benchmark run's folder or its cases.csv)"),
    "moving_missing_model": ("experiments/localization_benchmark/moving.py",
                             ["--model", "{tmp}/none.onnx", "--out", "{tmp}/out"],
                             "{tmp}/none.onnx: no such classifier (write one with vehloc-export)"),
    "moving_bad_setting": ("experiments/localization_benchmark/moving.py",
                           ["--out", "{tmp}/out", "--set", "tracker.min_iou=2"],
                           "tracker.min_iou: must be in [0, 1], got 2.0"),
    "speed_unknown_scene": ("experiments/speed/run.py", ["--model", "{tmp}/none.onnx", "--out", "{tmp}/out", "--cases",
                                                         "traffic_4k:1"],
                            "--cases 'traffic_4k:1': expected SCENE:SEED or SCENE:FIRST-LAST"),
}


@pytest.mark.parametrize("kind", SCRIPT_CASES)
def test_an_experiment_script_answers_bad_input_in_one_line(kind: str, tmp_path: Path) -> None:
    """The experiment scripts run under the same entry wrapper as the console scripts: a missing file is one line
    naming the script and the file, exit code 1, no traceback and nothing written."""
    script, args, fragment = SCRIPT_CASES[kind]
    project = Path(__file__).resolve().parents[1]
    result = subprocess.run([sys.executable, str(project / script), *(a.format(tmp=tmp_path) for a in args)],
                            capture_output=True, text=True, env=cli_env(), timeout=300)
    assert_one_error(result, script, fragment.format(tmp=tmp_path))
    assert "Traceback" not in result.stderr and not (tmp_path / "out").exists()


def test_a_read_only_run_folder_is_one_line_before_any_work(tmp_path: Path) -> None:
    """An existing run folder on a read-only file system failed inside Hydra's logging set-up with a traceback; it
    is one line naming the log file, exit code 1, before any input is read."""
    folder = tmp_path / "ro"
    (folder / "run").mkdir(parents=True)
    if not read_only_supported(folder):
        pytest.skip("cannot mount a read-only file system here")
    result = run_cli_read_only(folder, "vehloc-localize", f"video={tmp_path / 'none.avi'}",
                               f"calibration={tmp_path / 'none.json'}", f"model={tmp_path / 'none.onnx'}",
                               f"hydra.run.dir={folder / 'run'}")
    assert_one_error(result, "vehloc-localize", f"{folder / 'run' / 'localize.log'}: cannot write the run's log there",
                     "Read-only file system")
