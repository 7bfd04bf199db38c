"""The DataModule: enlarged ROI crops, transforms, validation carving, sampling, bad input."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import torch

from vehloc.errors import DataError
from vehloc.train.datamodule import CompCarsDataModule, carve_validation
from vehloc.train.dataset import load_roi


def test_roi_crop_is_the_enlarged_label_box(tiny_root: Path):
    dm = CompCarsDataModule(str(tiny_root), input_size_px=32, num_workers=0)
    sample = dm.dataset.train[0]  # box 1-based (3, 2, 38, 29) in a 40x30 image
    assert load_roi(sample, 0.0).shape == (28, 36, 3)
    assert load_roi(sample, 0.10).shape == (30, 40, 3)  # grown by 4 x 3 px a side, clipped to the image


def test_loaders_yield_normalisable_batches_with_indices(tiny_root: Path):
    dm = CompCarsDataModule(str(tiny_root), input_size_px=32, eval_resize_px=36, batch_size=4, num_workers=0)
    dm.setup("fit")
    images, labels, indices = next(iter(dm.train_dataloader()))
    assert images.shape == (4, 3, 32, 32) and images.dtype == torch.float32
    assert 0.0 <= images.min() and images.max() <= 1.0
    assert set(labels.tolist()) <= {0, 1, 2}
    test_images, test_labels, test_indices = next(iter(dm.test_dataloader()))
    assert test_images.shape == (3, 3, 32, 32)
    assert test_labels.tolist() == [0, 1, 2] and test_indices.tolist() == [0, 1, 2]
    assert dm.class_info() == {
        "class_model_ids": [11, 12, 25],
        "class_makes": ["MakeOne", "MakeOne", "MakeTwo"],
        "class_models": ["Alpha", "Beta", "Gamma"],
        "class_dims_mm": [[4500.0, 1800.0, 1450.0], [4600.0, 1850.0, 1470.0], [4000.0, 1700.0, 1600.0]],
        "class_wheelbases_mm": [2700.0, None, 2500.0],
    }


def test_validation_is_carved_per_class_from_train():
    labels = [0] * 10 + [1] * 4 + [2] * 1
    train, val = carve_validation(labels, 0.2, seed=1)
    assert sorted(train + val) == list(range(15)) and not set(train) & set(val)
    assert Counter(labels[i] for i in val) == {0: 2, 1: 1}  # a single-image class stays in train
    assert carve_validation(labels, 0.2, seed=1) == (train, val)


def test_val_split_from_train_or_test(tiny_root: Path):
    dm = CompCarsDataModule(str(tiny_root), input_size_px=32, num_workers=0, val_fraction=0.3)
    dm.setup("fit")
    assert len(dm.train_set) == 6 and len(dm.val_set) == 3 and len(dm.test_set) == 3
    val_paths = {s.rel_path for s in dm.val_set.samples}
    assert not val_paths & {s.rel_path for s in dm.train_set.samples}
    assert dm.test_split_warning == ""
    dm_test_val = CompCarsDataModule(str(tiny_root), input_size_px=32, num_workers=0, val_fraction=0.0,
                                     select_on_test=True)
    dm_test_val.setup("fit")
    assert [s.rel_path for s in dm_test_val.val_set.samples] == [s.rel_path for s in dm_test_val.test_set.samples]
    assert "chosen on this same test split" in dm_test_val.test_split_warning


def test_default_data_module_never_validates_on_the_test_split(tiny_root: Path):
    dm = CompCarsDataModule(str(tiny_root), input_size_px=32, num_workers=0)
    dm.setup("fit")
    test_paths = {s.rel_path for s in dm.test_set.samples}
    assert dm.val_set.samples and not {s.rel_path for s in dm.val_set.samples} & test_paths


def test_balanced_sampling_draws_classes_evenly(tiny_root: Path):
    dm = CompCarsDataModule(str(tiny_root), input_size_px=32, num_workers=0, balanced_sampling=True)
    dm.setup("fit")
    dm.train_set.labels = [0] * 7 + [1, 2]  # a skewed label list over the 9 images
    torch.manual_seed(0)
    drawn = Counter(dm.train_set.labels[i] for _ in range(300) for i in dm.train_dataloader().sampler)
    shares = [drawn[c] / sum(drawn.values()) for c in range(3)]
    assert all(abs(s - 1 / 3) < 0.05 for s in shares)


def test_missing_root_is_one_clear_error(tmp_path: Path):
    dm = CompCarsDataModule(str(tmp_path / "nowhere"))
    with pytest.raises(DataError, match=r"data.root .*nowhere: no such folder") as info:
        dm.class_info()
    assert "\n" not in str(info.value)


def test_specs_lacking_a_class_is_an_error(tiny_root: Path):
    specs = tiny_root / "specs.csv"
    specs.write_text("\n".join(line for line in specs.read_text().splitlines() if not line.startswith("25,")) + "\n")
    with pytest.raises(DataError, match="no dimensions for 1 class") as info:
        CompCarsDataModule(str(tiny_root)).class_info()
    assert "model 25 (Gamma)" in info.value.problems[0]
