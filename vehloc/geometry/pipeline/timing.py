"""Wall time per pipeline stage: a clock the localizer reports into, for benchmarks and run summaries."""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np


class StageClock:
    """Collects the seconds each named stage took, one entry per call."""

    def __init__(self) -> None:
        self.seconds: dict[str, list[float]] = defaultdict(list)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name].append(time.perf_counter() - start)

    def total_ms(self, name: str) -> float:
        return 1000.0 * float(np.sum(self.seconds.get(name, [])))

    def calls(self, name: str) -> int:
        return len(self.seconds.get(name, []))
