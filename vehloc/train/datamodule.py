"""LightningDataModule over a CompCars-format root: ROI crops, augmentation, samplers, splits."""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Sequence
from functools import cached_property
from pathlib import Path
from typing import Any

import lightning as L
import numpy as np
import torch
from torch.utils.data import DataLoader, WeightedRandomSampler

from vehloc.data.compcars import CompCarsSample, CompCarsSet
from vehloc.data.preprocess import Preprocessing
from vehloc.data.specs import SpecsTable
from vehloc.train.classes import class_info, read_dataset, read_specs
from vehloc.train.dataset import CompCarsCrops
from vehloc.train.params import DataParams
from vehloc.train.transforms import EvalTransform, TrainTransform


def carve_validation(labels: Sequence[int], val_fraction: float, seed: int) -> tuple[list[int], list[int]]:
    """Stratified split of train indices into (train, val): `val_fraction` of each class, at least one
    image of every class with two or more images."""
    rng = np.random.default_rng(seed)
    by_class: dict[int, list[int]] = {}
    for index, label in enumerate(labels):
        by_class.setdefault(label, []).append(index)
    train_idx, val_idx = [], []
    for label in sorted(by_class):
        members = rng.permutation(by_class[label]).tolist()
        n_val = min(len(members) - 1, max(1, round(val_fraction * len(members))))
        val_idx += members[:n_val]
        train_idx += members[n_val:]
    return sorted(train_idx), sorted(val_idx)


class CompCarsDataModule(L.LightningDataModule):
    """Train/val/test loaders of enlarged vehicle ROIs from a CompCars-format root.

    Validation (the choice of the best epoch) uses `val_fraction` of train, stratified; only with
    `select_on_test=True` (and `val_fraction=0`) the test split, which `test_split_warning` then names.
    Validation and test images go through `eval_preprocessing`: the data config's ROI enlargement, resize and
    input size until the model's own preprocessing is given with `use_preprocessing` (training does so; the
    evaluation of a checkpoint gives the checkpoint's).
    """

    def __init__(
        self,
        root: str,
        specs_csv: str | None = None,
        input_size_px: int = 224,
        eval_resize_px: int | None = None,
        roi_enlarge_fraction: float = 0.10,
        keep_aspect: bool = False,
        augment: dict[str, Any] | None = None,
        batch_size: int = 32,
        eval_batch_size: int | None = None,
        num_workers: int = 2,
        pin_memory: bool = False,
        balanced_sampling: bool = False,
        val_fraction: float = 0.1,
        select_on_test: bool = False,
        seed: int = 0,
    ) -> None:
        super().__init__()
        self.save_hyperparameters(logger=False)
        self.root = Path(root)
        self.specs_path = Path(specs_csv) if specs_csv else self.root / "specs.csv"
        self.augment = dict(augment or {})
        # the network's normalisation is unknown here and not part of `to_input`: identity until given
        self.eval_preprocessing = Preprocessing(
            input_size_px, eval_resize_px or input_size_px, roi_enlarge_fraction, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0),
            keep_aspect,
        )
        self.train_set: CompCarsCrops | None = None
        self.val_set: CompCarsCrops | None = None
        self.test_set: CompCarsCrops | None = None

    @classmethod
    def from_params(cls, data: DataParams) -> CompCarsDataModule:
        """The datamodule of checked settings (`vehloc.train.params.check_data`): the one way the entry points
        build it."""
        return cls(**dataclasses.asdict(data))

    @cached_property
    def dataset(self) -> CompCarsSet:
        return read_dataset(self.root)

    @cached_property
    def specs(self) -> SpecsTable:
        return read_specs(self.specs_path, self.dataset)

    def use_data(self, dataset: CompCarsSet, specs: SpecsTable) -> None:
        """Use a data set and specs table already read from this module's root (not read again)."""
        self.__dict__["dataset"], self.__dict__["specs"] = dataset, specs

    def class_info(self) -> dict[str, list]:
        """Model ids, make and model names, (L, W, H) and wheelbase in mm of the classes, in class-index order."""
        return class_info(self.dataset, self.specs)

    def use_preprocessing(self, preprocessing: Preprocessing) -> None:
        """Evaluate with a model's preprocessing (before `setup`)."""
        if self.test_set is not None:
            raise RuntimeError("use_preprocessing must come before setup")
        self.eval_preprocessing = preprocessing

    def _crops(self, samples: Sequence[CompCarsSample], labels: Sequence[int], train: bool) -> CompCarsCrops:
        if train:
            hp = self.hparams
            return CompCarsCrops(samples, labels, TrainTransform(hp.input_size_px, hp.keep_aspect, **self.augment), hp.roi_enlarge_fraction)
        preprocessing = self.eval_preprocessing
        return CompCarsCrops(samples, labels, EvalTransform(preprocessing), preprocessing.roi_enlarge_fraction)

    def setup(self, stage: str | None = None) -> None:
        if self.test_set is not None:
            return
        data = self.dataset
        self.specs.require(data.model_ids, data.model_names)
        train_samples, train_labels = data.train, data.labels("train")
        test_samples, test_labels = data.test, data.labels("test")
        if not self.hparams.select_on_test:
            keep, held_out = carve_validation(train_labels, self.hparams.val_fraction, self.hparams.seed)
            val_samples = [train_samples[i] for i in held_out]
            val_labels = [train_labels[i] for i in held_out]
            train_samples = [train_samples[i] for i in keep]
            train_labels = [train_labels[i] for i in keep]
        else:
            val_samples, val_labels = test_samples, test_labels
        self.train_set = self._crops(train_samples, train_labels, train=True)
        self.val_set = self._crops(val_samples, val_labels, train=False)
        self.test_set = self._crops(test_samples, test_labels, train=False)

    @property
    def test_split_warning(self) -> str:
        """The line a report opens with when the checkpoint was chosen on the test split it is scored on."""
        if not self.hparams.select_on_test:
            return ""
        return ("**Optimistic: the checkpoint was chosen on this same test split (data.select_on_test=true); "
                "these figures are not an unseen-data estimate.**")

    def _loader(self, dataset: CompCarsCrops, batch_size: int, shuffle: bool, sampler=None,
                drop_last: bool = False) -> DataLoader:
        workers = self.hparams.num_workers
        return DataLoader(
            dataset,
            batch_size=batch_size,
            shuffle=shuffle and sampler is None,
            sampler=sampler,
            num_workers=workers,
            pin_memory=self.hparams.pin_memory,
            persistent_workers=workers > 0,
            drop_last=drop_last,
        )

    def _balanced_sampler(self, labels: Sequence[int]) -> WeightedRandomSampler:
        counts = Counter(labels)
        weights = torch.tensor([1.0 / counts[label] for label in labels], dtype=torch.double)
        return WeightedRandomSampler(weights, num_samples=len(labels), replacement=True)

    def train_dataloader(self) -> DataLoader:
        sampler = self._balanced_sampler(self.train_set.labels) if self.hparams.balanced_sampling else None
        # a last batch of one image would break batch normalisation in training; each process sees its share
        per_process = len(self.train_set) // (self.trainer.world_size if self.trainer is not None else 1)
        return self._loader(self.train_set, self.hparams.batch_size, shuffle=True, sampler=sampler,
                            drop_last=per_process > self.hparams.batch_size)

    def val_dataloader(self) -> DataLoader:
        return self._loader(self.val_set, self.hparams.eval_batch_size or self.hparams.batch_size, shuffle=False)

    def test_dataloader(self) -> DataLoader:
        return self._loader(self.test_set, self.hparams.eval_batch_size or self.hparams.batch_size, shuffle=False)
