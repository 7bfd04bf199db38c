"""Reading classifier checkpoints (torch only, no Lightning): always with `weights_only=True`, so that a file
from elsewhere can never run code, with one clear line when a file is not a vehloc checkpoint; the
checkpoint's preprocessing; and the check that a checkpoint's classes are those of a data set."""

from __future__ import annotations

import pickle
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vehloc.data.preprocess import Preprocessing
from vehloc.errors import VehlocError
from vehloc.train.classes import class_mismatch

PREPROCESSING_KEY = "preprocessing"
CLASS_TABLE_KEYS = ("class_model_ids", "class_makes", "class_models", "class_dims_mm")


class CheckpointError(VehlocError):
    """A checkpoint is missing, unreadable, not a vehloc classifier's, or of other classes than the data."""


def load_failure(exc: BaseException) -> str:
    """Why torch.load failed, in a few words (never PyTorch's advice to load the file with weights_only=False,
    which would let an untrusted file run code)."""
    text = str(exc)
    if "Unsupported global" in text or "GLOBAL" in text:
        return ("it holds Python objects besides tensors and plain values; vehloc loads checkpoints with "
                "weights_only=True and does not run code from a file")
    if isinstance(exc, EOFError) or "Ran out of input" in text:
        return "the file is empty or cut short"
    if isinstance(exc, zipfile.BadZipFile) or "zip archive" in text or "central directory" in text:
        return "the file is cut short or corrupt (a broken zip archive)"
    if isinstance(exc, (pickle.UnpicklingError, RuntimeError, ValueError)) or "Weights only load failed" in text:
        return "the file is corrupt or not a PyTorch checkpoint"
    return f"{type(exc).__name__}"


def check_checkpoint_file(path: str | Path) -> Path:
    """`path` as a Path; CheckpointError naming it when it is no file (torch-free: a CLI says so before torch loads)."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"ckpt_path {path}: no such checkpoint file" + (" (it is a folder)" if path.is_dir() else ""))
    return path


def read_checkpoint(path: str | Path) -> dict[str, Any]:
    """A Lightning checkpoint of LitVehicleClassifier, loaded with `weights_only=True`; CheckpointError naming
    the file when it is missing, not loadable or not a vehloc classifier's."""
    path = check_checkpoint_file(path)
    import torch  # after the path's check: a missing file is named before torch loads

    try:
        checkpoint = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error here
        raise CheckpointError(f"{path}: not a readable checkpoint: {load_failure(exc)}") from None
    hparams = checkpoint.get("hyper_parameters") if isinstance(checkpoint, dict) else None
    if not isinstance(hparams, dict) or "state_dict" not in checkpoint or "class_model_ids" not in hparams:
        raise CheckpointError(f"{path}: not a vehloc classifier checkpoint (no state_dict and class table)")
    lengths = {key: len(hparams.get(key) or ()) for key in CLASS_TABLE_KEYS}
    if len(set(lengths.values())) != 1 or not lengths["class_model_ids"]:
        raise CheckpointError(f"{path}: malformed class table ({', '.join(f'{k}: {n}' for k, n in lengths.items())})")
    return checkpoint


def preprocessing_of(checkpoint: dict[str, Any], path: str | Path) -> Preprocessing:
    """The preprocessing a checkpoint's classifier was trained with."""
    if PREPROCESSING_KEY not in checkpoint:
        raise CheckpointError(f"{path}: the checkpoint has no preprocessing description (written by an older vehloc)")
    try:
        return Preprocessing.from_dict(checkpoint[PREPROCESSING_KEY])
    except (TypeError, ValueError) as err:
        raise CheckpointError(f"{path}: bad preprocessing description ({err})") from None


def chosen_on_test_split(checkpoint: dict[str, Any]) -> bool:
    """Whether the run that wrote the checkpoint validated on the test split (`data.select_on_test=true`, or
    `val_fraction=0` before that setting existed); False when the checkpoint does not say."""
    data = checkpoint.get("datamodule_hyper_parameters") or {}
    if "select_on_test" in data:
        return bool(data["select_on_test"])
    return data.get("val_fraction", 1.0) == 0.0


def check_classes(checkpoint: dict[str, Any], classes: Mapping[str, Sequence], path: str | Path, data_name: str) -> None:
    """CheckpointError unless the checkpoint was trained on exactly the `classes` of a data set
    (`vehloc.train.classes.class_info`): the same model ids in the same order and the same make and model names; the
    message says how they differ."""
    hp = checkpoint["hyper_parameters"]
    mismatch = class_mismatch("checkpoint", hp["class_model_ids"], list(zip(hp["class_makes"], hp["class_models"])),
                              classes["class_model_ids"], list(zip(classes["class_makes"], classes["class_models"])),
                              data_name)
    if mismatch:
        raise CheckpointError(f"{path}: {mismatch}")
