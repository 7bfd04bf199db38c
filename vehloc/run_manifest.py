"""A run folder's manifest: the files a tool wrote there (`outputs.json`), so that a later run into the same folder
removes exactly its predecessor's outputs before it writes its own (no old Table 2 beside new records), and never a
file the tool did not write."""

from __future__ import annotations

import json
import time
from pathlib import Path

from vehloc.atomic import write_text

MANIFEST_FILE = "outputs.json"
KEPT = (".hydra",)
"""What a run folder holds that is not the tool's output to replace: Hydra's record of the run."""


def earlier_outputs(run_dir: Path) -> list[Path]:
    """The files the manifest of an earlier run in `run_dir` names (none without one, or with an unreadable one)."""
    manifest = run_dir / MANIFEST_FILE
    try:
        names = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    inside = run_dir.resolve()
    paths = [(run_dir / str(name)) for name in names]
    return [p for p in paths if inside in p.resolve().parents and p.is_file()]


class RunManifest:
    """Made before a run writes (it removes the earlier run's outputs), `close`d after (it names what this run
    wrote: the files changed since it was made, the logs and Hydra's folder aside)."""

    def __init__(self, run_dir: Path) -> None:
        self.run_dir = Path(run_dir)
        for path in earlier_outputs(self.run_dir):
            path.unlink()
        (self.run_dir / MANIFEST_FILE).unlink(missing_ok=True)
        self.started_ns = time.time_ns()

    def close(self) -> Path:
        written = sorted(
            str(p.relative_to(self.run_dir)) for p in self.run_dir.rglob("*")
            if p.is_file() and p.stat().st_mtime_ns >= self.started_ns and p.suffix != ".log"
            and p.relative_to(self.run_dir).parts[0] not in KEPT and p.name != MANIFEST_FILE
        )
        return write_text(self.run_dir / MANIFEST_FILE, json.dumps({"files": written}, indent=1) + "\n")
