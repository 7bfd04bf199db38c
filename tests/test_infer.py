"""ONNX export (checks, parity, metadata, atomic write) and the onnxruntime classifier."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import onnx
import onnxruntime as ort
import pandas as pd
import pytest
import torch
from onnx import TensorProto, helper

from vehloc.data.compcars import read_compcars
from vehloc.data.shapes import SHAPES_FILE, read_shapes
from vehloc.infer.classifier import VehicleClassifier
from vehloc.train.export import ExportError, export_checkpoint, file_sha256, metadata_of
from vehloc.infer.metadata import ModelFileError
from vehloc.infer.predict_cli import main as predict_main
from vehloc.infer.preprocess import ImageInputError
from vehloc.synth.demo_set import make_demo_set
from vehloc.train.instantiate import compose_config
from vehloc.train.module import preprocessing_of, read_checkpoint
from vehloc.train.train import train

pytestmark = pytest.mark.slow  # trains small networks and exports them


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A GoogLeNet trained briefly on a small demo set and tested (Table 1 in run/table1), evaluating the mean of
    each image's and its mirror image's logits: (data root, best checkpoint)."""
    folder = tmp_path_factory.mktemp("infer")
    root = make_demo_set(folder / "demo", per_model=8, seed=3, workers=1)
    cfg = compose_config(
        "train",
        [
            "experiment=demo_googlenet_scratch", f"data.root={root}", "data.input_size_px=64", "data.eval_resize_px=72",
            "data.num_workers=0", "trainer.max_epochs=2", "logger=[]", "callbacks.model_summary.max_depth=0",
            "model.flip_average=true",
        ],
        output_dir=folder / "run",
    )
    _, objects = train(cfg)
    return root, Path(objects["trainer"].checkpoint_callback.best_model_path)


@pytest.fixture(scope="module")
def exported(trained: tuple[Path, Path], tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """The checkpoint exported once by `vehloc-export`, the demo set's shapes in its metadata: (file, stdout); the
    checkpoint read once (checked, then exported as read)."""
    root, checkpoint = trained
    folder = tmp_path_factory.mktemp("onnx")
    run = subprocess.run(
        [sys.executable, "-c", COUNTING_TORCH_LOADS, f"ckpt_path={checkpoint}", f"output={folder / 'model.onnx'}",
         f"data_root={root}", "parity_images=24", f"hydra.run.dir={folder / 'run'}"],
        capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stderr
    assert run.stderr.count(f"torch.load {checkpoint}") == 1, run.stderr  # the checkpoint is read once
    return folder / "model.onnx", run.stdout


# vehloc-export run with every torch.load it makes told on stderr
COUNTING_TORCH_LOADS = """
import runpy, sys, torch
load = torch.load
def told(path, *args, **kwargs):
    print(f"torch.load {path}", file=sys.stderr)
    return load(path, *args, **kwargs)
torch.load = told
sys.argv[0] = "vehloc-export"
runpy.run_module("vehloc.infer.export_cli", run_name="__main__", alter_sys=True)
"""


def test_export_passes_parity_on_real_images(exported: tuple[Path, str]) -> None:
    """Tolerance (issue): max |logit diff| <= 1e-4 and the same top-1 on every test image."""
    output, stdout = exported
    found = re.search(r"parity on (\d+) test images .*: max \|logit diff\| (\S+), same top-1 on (\d+)%", stdout)
    assert found, stdout
    assert int(found[1]) == 24 and float(found[2]) <= 1e-4 and found[3] == "100"
    model = onnx.load(str(output))
    onnx.checker.check_model(model, full_check=True)
    assert max(o.version for o in model.opset_import if o.domain in ("", "ai.onnx")) >= 17
    assert not list(output.parent.glob(".*.tmp"))


def test_metadata_round_trip(trained: tuple[Path, Path], exported: tuple[Path, str]) -> None:
    _, checkpoint_path = trained
    output, _ = exported
    hp = read_checkpoint(checkpoint_path)["hyper_parameters"]
    meta = VehicleClassifier.from_onnx(output).metadata
    assert [c.model_id for c in meta.classes] == hp["class_model_ids"]
    assert [c.make for c in meta.classes] == hp["class_makes"] and [c.model for c in meta.classes] == hp["class_models"]
    np.testing.assert_allclose(meta.dims_mm, hp["class_dims_mm"])
    assert meta.preprocessing == preprocessing_of(read_checkpoint(checkpoint_path), checkpoint_path)
    p = meta.preprocessing
    assert (p.input_size_px, p.resize_px, p.roi_enlarge_fraction) == (64, 72, 0.10) and p.mean == (0.485, 0.456, 0.406)
    assert p.colour_order == "RGB" and meta.backbone == "googlenet"
    assert meta.source_checkpoint_sha256 == file_sha256(checkpoint_path)
    assert meta.classes[0].make == "BMW" and meta.classes[0].length_mm == 5250
    assert [c.wheelbase_mm for c in meta.classes] == hp["class_wheelbases_mm"] and meta.classes[0].wheelbase_mm == 3210


def test_dynamic_batch_and_predictions(trained: tuple[Path, Path], exported: tuple[Path, str]) -> None:
    root, _ = trained
    classifier = VehicleClassifier.from_onnx(exported[0])
    samples = read_compcars(root).test[:7]
    paths, boxes = [s.image_path for s in samples], [s.box for s in samples]
    one_by_one = np.concatenate([classifier.probabilities([p], [b]) for p, b in zip(paths, boxes)])
    np.testing.assert_allclose(classifier.probabilities(paths, boxes, batch_size=4), one_by_one, atol=1e-5)
    crops = [b.crop(cv2.imread(str(p))) for p, b in zip(paths, boxes)]
    assert not np.allclose(classifier.probabilities(crops), one_by_one, atol=1e-3)  # the box without enlargement
    prediction = classifier.predict(paths[:1], top_k=3, boxes=boxes[:1])[0]
    assert len(prediction.top_k) == 3 and prediction.top_k[0].probability >= prediction.top_k[1].probability
    top1 = next(c for c in classifier.classes if c.model_id == prediction.top1.model_id)
    np.testing.assert_allclose(prediction.top1_dims_mm, [top1.length_mm, top1.width_mm, top1.height_mm])
    assert np.all(classifier.metadata.dims_mm.min(0) <= prediction.expected_dims_mm)
    assert np.all(prediction.expected_dims_mm <= classifier.metadata.dims_mm.max(0))


def test_predict_from_the_image_files_gives_table1s_predictions(
    trained: tuple[Path, Path], exported: tuple[Path, str], tmp_path: Path, capsys
) -> None:
    """Table 1 (the training code's evaluation, PyTorch) and vehloc-predict (ONNX, from the image files and
    their labels) on the test split: the same class for >= 99.5 % of the images, probabilities within 1e-3."""
    root, checkpoint = trained
    table1 = pd.read_csv(checkpoint.parent.parent / "table1" / "predictions.csv")
    csv = tmp_path / "p.csv"
    images = [str(root / "image" / rel) for rel in table1["image"]]
    assert predict_main(["--model", str(exported[0]), "--compcars-labels", "--top-k", "1", "--csv", str(csv), *images]) == 0
    capsys.readouterr()
    predicted = pd.read_csv(csv)
    assert len(predicted) == len(table1) == 24
    assert np.mean(predicted["model_id"].to_numpy() == table1["pred_model_id"].to_numpy()) >= 0.995
    assert np.max(np.abs(predicted["probability"].to_numpy() - table1["pred_prob"].to_numpy())) <= 1e-3


def test_failed_export_leaves_the_good_file(trained: tuple[Path, Path], exported: tuple[Path, str],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """A model that fails its parity check (tolerance -1) replaces nothing and leaves no temporary file. The
    exporter's graph is stood in by the good file's (the same checkpoint's export, its metadata stripped), so the
    checks after the export run as they do on a fresh one without a second export."""
    root, checkpoint = trained
    output, _ = exported
    before = output.read_bytes()
    graph = onnx.load(str(output))
    del graph.metadata_props[:]

    def stand_in_export(model, args, path: str, **kwargs) -> None:
        onnx.save(graph, path)

    monkeypatch.setattr(torch.onnx, "export", stand_in_export)
    with pytest.raises(ExportError, match="left unchanged"):
        export_checkpoint(checkpoint, output, read_compcars(root).test[:4], tolerance=-1.0)
    assert output.read_bytes() == before and not list(output.parent.glob(".*.tmp"))
    with pytest.raises(ExportError, match="opset 16 is below 17"):
        export_checkpoint(checkpoint, output, [], opset=16)


def test_model_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match="model file does not exist"):
        VehicleClassifier.from_onnx(tmp_path / "none.onnx")
    (tmp_path / "corrupt.onnx").write_bytes(b"\x08\x07garbage")
    with pytest.raises(ModelFileError, match="not a loadable ONNX model"):
        VehicleClassifier.from_onnx(tmp_path / "corrupt.onnx")
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])], "plain",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])], [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
    )
    plain = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    onnx.save(plain, str(tmp_path / "plain.onnx"))
    with pytest.raises(ModelFileError, match="without vehloc metadata"):
        VehicleClassifier.from_onnx(tmp_path / "plain.onnx")


def test_image_input_errors(exported: tuple[Path, str], tmp_path: Path) -> None:
    classifier = VehicleClassifier.from_onnx(exported[0])
    (tmp_path / "notes.txt").write_text("not an image")
    with pytest.raises(ImageInputError, match="notes.txt: not a readable image"):
        classifier.predict([tmp_path / "notes.txt"])
    with pytest.raises(ImageInputError, match="expected a colour BGR image"):
        classifier.predict([np.zeros((40, 40), np.uint8)])
    grey = np.random.default_rng(0).integers(0, 256, (40, 40), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "grey.png"), grey)  # a grey file reads as colour, as in training
    np.testing.assert_allclose(classifier.probabilities([tmp_path / "grey.png"]),
                               classifier.probabilities([np.repeat(grey[:, :, None], 3, axis=2)]), atol=1e-6)
    with pytest.raises(ImageInputError, match="1x1 px is too small"):
        classifier.predict([np.zeros((1, 1, 3), np.uint8)])


def test_predict_cli(trained: tuple[Path, Path], exported: tuple[Path, str], tmp_path: Path, capsys) -> None:
    root, _ = trained
    images = [s.image_path for s in read_compcars(root).test[:2]]
    assert predict_main(["--model", str(exported[0]), *map(str, images), "--top-k", "2", "--csv", str(tmp_path / "p.csv")]) == 0
    out = capsys.readouterr().out
    assert "probability" in out and str(images[0]) in out
    assert len((tmp_path / "p.csv").read_text().splitlines()) == 1 + 2 * 2


def test_predict_cli_crops_whole_compcars_images_to_their_labels(
    trained: tuple[Path, Path], exported: tuple[Path, str], tmp_path: Path, capsys
) -> None:
    root, _ = trained
    samples = read_compcars(root).test[:3]
    csv = tmp_path / "p.csv"
    argv = ["--model", str(exported[0]), "--compcars-labels", "--top-k", "1", "--csv", str(csv)]
    assert predict_main([*argv, *(str(s.image_path) for s in samples)]) == 0
    table = pd.read_csv(csv)
    reference = VehicleClassifier.from_onnx(exported[0]).predict(
        [s.image_path for s in samples], top_k=1, boxes=[s.box for s in samples])
    assert table["model_id"].tolist() == [p.top_k[0].model_id for p in reference]
    np.testing.assert_allclose(table["probability"], [p.top_k[0].probability for p in reference], atol=1e-4)
    capsys.readouterr()

    orphan = tmp_path / "image" / "1" / "1" / "2013" / "0000.jpg"
    orphan.parent.mkdir(parents=True)
    orphan.write_bytes(samples[0].image_path.read_bytes())
    with pytest.raises(SystemExit) as exit_info:
        predict_main([*argv, str(orphan)])
    assert exit_info.value.code == 1
    err = capsys.readouterr().err
    assert "vehloc-predict: error:" in err and str(tmp_path / "label" / "1" / "1" / "2013" / "0000.txt") in err
    loose = tmp_path / "loose.jpg"
    loose.write_bytes(samples[0].image_path.read_bytes())
    with pytest.raises(SystemExit):
        predict_main([*argv, str(loose)])
    assert "not under an image/ folder" in capsys.readouterr().err


def test_export_cli_puts_the_shapes_in_and_metadata_without_them_falls_back_to_cuboids(
    trained: tuple[Path, Path], exported: tuple[Path, str]
) -> None:
    root, checkpoint = trained
    output, stdout = exported
    assert f"with the shapes of {root / SHAPES_FILE}" in stdout
    metadata = VehicleClassifier.from_onnx(output).metadata
    shapes = read_shapes(root / SHAPES_FILE)
    assert sorted(metadata.shapes) == sorted(c.model_id for c in metadata.classes) == sorted(shapes)
    np.testing.assert_allclose(metadata.shape_of(1).points_mm, shapes[1].points_mm, atol=0.05)  # 0.1 mm rounding
    without = metadata_of(read_checkpoint(checkpoint), checkpoint)  # no shapes given: the cuboids of the specs
    spec = without.classes[0]
    np.testing.assert_allclose(np.ptp(without.shape_of(spec.model_id).points_mm, axis=0), spec.dims_mm)


def test_flip_average_is_inside_the_exported_graph(exported: tuple[Path, str], trained: tuple[Path, Path]) -> None:
    """The model was trained with flip averaging: the exported graph averages too, so an input and its mirror
    image give the same logits (1e-4; a single view's logits differ by far more)."""
    output, _ = exported
    root, checkpoint = trained
    assert read_checkpoint(checkpoint)["hyper_parameters"]["flip_average"] is True
    classifier = VehicleClassifier.from_onnx(output)
    inputs = classifier.inputs([s.image_path for s in read_compcars(root).test[:4]])
    session = ort.InferenceSession(str(output), providers=["CPUExecutionProvider"])
    name = classifier.metadata.input_name
    logits = session.run(["logits"], {name: inputs})[0]
    mirrored = session.run(["logits"], {name: np.ascontiguousarray(inputs[..., ::-1])})[0]
    np.testing.assert_allclose(mirrored, logits, atol=1e-4)


@pytest.fixture(scope="module")
def quantized(trained: tuple[Path, Path], exported: tuple[Path, str]) -> tuple[Path, str, bytes]:
    """The exported model quantized by `vehloc-export onnx_path=... quantize=int8`: (INT8 file, stdout, the fp32
    file's bytes before)."""
    root, _ = trained
    fp32 = exported[0]
    before = fp32.read_bytes()
    run = subprocess.run(
        [sys.executable, "-m", "vehloc.infer.export_cli", f"onnx_path={fp32}", "quantize=int8", f"data_root={root}",
         "parity_images=24", "int8.calibration_images=40", "int8.min_top1_agreement=0.5",
         f"hydra.run.dir={fp32.parent / 'run_int8'}"],
        capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stderr
    return fp32.with_name("model.int8.onnx"), run.stdout, before


def test_int8_export_is_checked_and_carries_how_it_was_made(quantized: tuple[Path, str, bytes],
                                                             exported: tuple[Path, str]) -> None:
    """The INT8 file lands beside the fp32 one (left as it was), with the fp32 metadata plus what was quantized,
    how, and the figures it was checked on; its stdout states the test split's accuracy of both."""
    int8_path, stdout, fp32_before = quantized
    assert exported[0].read_bytes() == fp32_before
    fp32, int8 = VehicleClassifier.from_onnx(exported[0]), VehicleClassifier.from_onnx(int8_path)
    assert fp32.metadata.precision == "fp32" and int8.metadata.precision == "int8"
    assert int8.classes == fp32.classes and int8.metadata.preprocessing == fp32.metadata.preprocessing
    notes = int8.metadata.notes
    assert notes["fp32_model_sha256"] == file_sha256(exported[0]) and notes["test_images"] == "24"
    assert "per channel" in notes["quantization"] and notes["calibration"].startswith("40 training images")
    graph = onnx.load(str(int8_path)).graph
    assert {"QuantizeLinear", "DequantizeLinear"} <= {node.op_type for node in graph.node}
    # the head stays float: the logits come from a float operator, not off an 8-bit grid (which ties classes)
    logits_producer = next(node for node in graph.node if int8.metadata.output_names[0] in node.output)
    assert logits_producer.op_type != "DequantizeLinear"
    found = re.search(r"top-1 fp32 ([\d.]+) %, INT8 ([\d.]+) % \(loss ([+-][\d.]+) points\)", stdout)
    assert found, stdout
    assert (found[1], found[2]) == (notes["test_top1_fp32_pct"], notes["test_top1_int8_pct"])
    assert float(found[3]) == pytest.approx(float(found[1]) - float(found[2]), abs=0.011)
    # the INT8 model is a different computation (not a copy) that still ranks like the fp32 one
    samples = read_compcars(trained_root(exported)).test
    p32 = fp32.probabilities([s.image_path for s in samples], [s.box for s in samples])
    p8 = int8.probabilities([s.image_path for s in samples], [s.box for s in samples])
    assert 1e-6 < np.max(np.abs(p32 - p8)) < 0.2


def trained_root(exported: tuple[Path, str]) -> Path:
    """The data root the exported model was checked on (from its export's command line, in its run folder)."""
    overrides = (exported[0].parent / "run" / ".hydra" / "overrides.yaml").read_text()
    return Path(re.search(r"data_root=(\S+)", overrides)[1])


def test_onnx_eval_reproduces_the_checkpoints_table1_and_measures_the_int8_model(
    trained: tuple[Path, Path], exported: tuple[Path, str], quantized: tuple[Path, str, bytes], tmp_path: Path,
) -> None:
    """`vehloc-eval onnx_path=`: the fp32 model's per-image ranks equal the checkpoint's Table 1 (PyTorch) on every
    test image; the INT8 model's top-1 is the one its export measured (the same code)."""
    root, checkpoint = trained
    checkpoint_table = pd.read_csv(checkpoint.parent.parent / "table1" / "predictions.csv")
    for name, model in (("fp32", exported[0]), ("int8", quantized[0])):
        run = subprocess.run(
            [sys.executable, "-m", "vehloc.train.evaluate", f"onnx_path={model}", f"data.root={root}",
             f"hydra.run.dir={tmp_path / name}"], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        table = pd.read_csv(tmp_path / name / "table1" / "predictions.csv")
        assert table["image"].tolist() == checkpoint_table["image"].tolist()
        report = (tmp_path / name / "table1" / "report.md").read_text()
        assert f"{name.upper()} model, onnxruntime" in report
        if name == "fp32":
            assert table["rank"].tolist() == checkpoint_table["rank"].tolist()
            np.testing.assert_allclose(table["pred_prob"], checkpoint_table["pred_prob"], atol=1e-3)
        else:
            top1 = pd.read_csv(tmp_path / name / "table1" / "accuracy.csv").set_index("metric")["value"]["top1_pct"]
            assert f"{top1:.2f}" == VehicleClassifier.from_onnx(model).metadata.notes["test_top1_int8_pct"]


def test_int8_refusals(exported: tuple[Path, str], quantized: tuple[Path, str, bytes], tmp_path: Path) -> None:
    """An INT8 model is not quantized again, nor taken as a checkpoint; an INT8 model that disagrees with its fp32
    model on too many parity images is not written."""
    from vehloc.infer.quantize import Int8Settings, QuantizationError, quantize_classifier

    root = trained_root(exported)
    data = read_compcars(root)
    with pytest.raises(QuantizationError, match="is already an int8 model"):
        quantize_classifier(quantized[0], tmp_path / "again.onnx", data.train[:4], data.test[:4], data.test,
                            Int8Settings(), str(root))
    # one calibration image of another kind than the test images sets ranges that flip some of their top-1
    output = tmp_path / "strict.onnx"
    output.write_bytes(b"an earlier model")
    with pytest.raises(QuantizationError, match=r"agrees with the fp32 one on .* left unchanged"):
        quantize_classifier(exported[0], output, data.train[:1], data.test, data.test,
                            Int8Settings(min_top1_agreement=1.0), str(root))
    assert output.read_bytes() == b"an earlier model" and not list(tmp_path.glob(".*.tmp"))
