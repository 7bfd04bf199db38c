"""Cases run side by side in worker processes, their results yielded in the order given: each worker with one
OpenCV and one OpenMP thread (the workers share the cores) and its classifier loaded once (the localization, speed
and automatic-calibration benchmarks)."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import cv2

from vehloc.infer.classifier import VehicleClassifier

Result = TypeVar("Result")

_worker_classifier: VehicleClassifier | None = None


def worker_classifier() -> VehicleClassifier | None:
    """The classifier this process's cases use (None: none was given)."""
    return _worker_classifier


def _load_classifier(model: Path | None) -> None:
    global _worker_classifier
    _worker_classifier = None if model is None else VehicleClassifier.from_onnx(model)


def _start_worker(model: Path | None) -> None:
    cv2.setNumThreads(1)
    _load_classifier(model)


@contextmanager
def _single_threaded_children() -> Iterator[None]:
    """OpenMP one thread in the processes started inside, the caller's environment restored after."""
    before = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = "1"
    try:
        yield
    finally:
        if before is None:
            del os.environ["OMP_NUM_THREADS"]
        else:
            os.environ["OMP_NUM_THREADS"] = before


def in_order(function: Callable[..., Result], jobs: Sequence[tuple[Any, ...]], workers: int,
             model: Path | None = None) -> Iterator[Result]:
    """`function(*job)` for every job, `workers` side by side (1: in this process), yielded in the jobs' order as
    each completes; `worker_classifier()` is the classifier exported to `model` wherever they run."""
    if workers == 1:
        _load_classifier(model)
        for job in jobs:
            yield function(*job)
        return
    spawn = multiprocessing.get_context("spawn")  # a forked child of a process with OpenMP threads can hang
    with ProcessPoolExecutor(workers, mp_context=spawn, initializer=_start_worker, initargs=(model,)) as pool:
        with _single_threaded_children():  # the workers start as the jobs are submitted
            futures = [pool.submit(function, *job) for job in jobs]
        for future in futures:
            yield future.result()
