"""Which steps of a run folder are done: a step's stamp records the settings it ran with and the files it
wrote; the step is skipped while the stamp matches and those files exist."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from vehloc.atomic import write_text

STAMP_DIR = ".steps"


def _stamp_path(run_dir: Path, step: str) -> Path:
    return run_dir / STAMP_DIR / f"{step}.json"


def is_done(run_dir: Path, step: str, settings: dict[str, Any]) -> bool:
    """True when `step` finished with these `settings` and every file it wrote is still there."""
    path = _stamp_path(run_dir, step)
    try:
        stamp = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    if stamp.get("settings") != json.loads(json.dumps(settings)):
        return False
    return all((run_dir / name).exists() for name in stamp.get("outputs", []))


def mark_done(run_dir: Path, step: str, settings: dict[str, Any], outputs: list[Path], seconds: float) -> None:
    """Record that `step` finished with `settings` in `seconds`, having written `outputs` (inside `run_dir`)."""
    names = [str(Path(p).resolve().relative_to(run_dir.resolve())) for p in outputs]
    stamp = {"settings": settings, "outputs": names, "seconds": round(seconds, 1)}
    write_text(_stamp_path(run_dir, step), json.dumps(stamp, indent=1) + "\n")


def seconds_taken(run_dir: Path, step: str) -> float | None:
    """How long `step` took when it last ran to the end (None without a stamp)."""
    try:
        return float(json.loads(_stamp_path(run_dir, step).read_text(encoding="utf-8"))["seconds"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def finished_at(run_dir: Path, step: str) -> int | None:
    """When `step` last finished (its stamp's time, ns), so that the steps after a redone one are redone."""
    path = _stamp_path(run_dir, step)
    return path.stat().st_mtime_ns if path.is_file() else None


def forget(run_dir: Path, step: str) -> None:
    """Mark `step` as not done (its stamp removed), before it runs again."""
    _stamp_path(run_dir, step).unlink(missing_ok=True)
