"""One table of a `vehloc-localize -m video=a.avi,b.avi,...` multirun, on any launcher: a row per video (done or
failed and why, records, localized, vehicles, speeds measured and their median) and every vehicle of every video
(`tracks.csv` of each, with its video), written into the multirun's folder when the last job has ended."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from hydra.experimental.callback import Callback

from vehloc.atomic import atomic_path, write_text
from vehloc.errors import running_prog
from vehloc.multirun import JobFolder, job_folders, report_failed_jobs
from vehloc.tables import markdown_table

if TYPE_CHECKING:
    import pandas as pd

VIDEOS_STEM = "multirun_videos"
VEHICLES_FILE = "multirun_vehicles.csv"


@dataclass(frozen=True)
class MultirunTables:
    """A row per job (video) and a row per vehicle of every video."""

    videos: pd.DataFrame
    vehicles: pd.DataFrame


def _job_video(job: JobFolder) -> str:
    config = job.path / ".hydra" / "config.yaml"
    if config.is_file():
        return str((yaml.safe_load(config.read_text(encoding="utf-8")) or {}).get("video", ""))
    return next((o.split("=", 1)[1] for o in job.overrides if o.startswith("video=")), "")


def _job_rows(job: JobFolder) -> tuple[dict[str, object], pd.DataFrame]:
    import pandas as pd  # imported on use: every vehloc-localize run loads this callback

    row: dict[str, object] = {"job": job.number, "video": _job_video(job), "status": "failed" if job.error else "done",
                              "reason": job.error or "", "records": 0, "localized": 0, "vehicles": 0,
                              "speeds_measured": 0, "median_speed_kmh": np.nan}
    records_file, tracks_file = job.path / "records.json", job.path / "tracks.csv"
    if job.error is None and not records_file.is_file():
        row.update(status="failed", reason="the job wrote no records (it was stopped, or its folder was removed)")
    if job.error is not None or not records_file.is_file():
        return row, pd.DataFrame()
    rows = json.loads(records_file.read_text(encoding="utf-8"))
    records = {(r["track_id"], r["frame"]): r["status"] for r in rows}
    row.update(records=len(records), localized=sum(status == "localized" for status in records.values()))
    tracks = pd.read_csv(tracks_file) if tracks_file.is_file() and tracks_file.stat().st_size > 1 else pd.DataFrame()
    if len(tracks):
        measured = tracks[tracks["status"] == "measured"]
        row.update(vehicles=len(tracks), speeds_measured=len(measured),
                   median_speed_kmh=float(measured["speed_kmh"].median()) if len(measured) else np.nan)
        tracks.insert(0, "video", row["video"])
        tracks.insert(0, "job", job.number)
    return row, tracks


def merge_localize_jobs(sweep_dir: Path) -> MultirunTables:
    """The tables of the jobs under `sweep_dir` (see the module docstring)."""
    import pandas as pd  # imported on use: every vehloc-localize run loads this callback

    rows, vehicles = [], []
    for job in job_folders(sweep_dir):
        row, tracks = _job_rows(job)
        rows.append(row)
        if len(tracks):
            vehicles.append(tracks)
    return MultirunTables(pd.DataFrame(rows), pd.concat(vehicles, ignore_index=True) if vehicles else pd.DataFrame())


def write_multirun_tables(tables: MultirunTables, sweep_dir: Path) -> list[Path]:
    """`multirun_videos.csv` / `.md` / `.png` and `multirun_vehicles.csv` in `sweep_dir`."""
    videos = tables.videos
    written = [write_text(sweep_dir / f"{VIDEOS_STEM}.csv", videos.to_csv(index=False, float_format="%.2f")),
               write_text(sweep_dir / VEHICLES_FILE, tables.vehicles.to_csv(index=False, float_format="%.3f"))]
    done = videos[videos["status"] == "done"]
    summary = (f"{len(done)} of {len(videos)} videos done; {int(done['vehicles'].sum())} vehicles, "
               f"{int(done['speeds_measured'].sum())} speeds measured, {int(done['localized'].sum())} records localized.")
    shown = videos.astype(object).where(videos.notna(), "")
    written.append(write_text(sweep_dir / f"{VIDEOS_STEM}.md", "\n\n".join(
        ["# vehloc-localize multirun", summary, markdown_table(shown), f"Every vehicle: `{VEHICLES_FILE}`."]) + "\n"))
    written.append(_write_png(tables, sweep_dir / f"{VIDEOS_STEM}.png"))
    return written


def _write_png(tables: MultirunTables, path: Path) -> Path:
    """Per video: its vehicles' speeds (dots) over bars of its vehicle count; failed videos marked."""
    from matplotlib.figure import Figure  # imported on use: every vehloc-localize run loads this callback

    videos = tables.videos
    fig = Figure(figsize=(max(6.0, 1.2 * len(videos) + 3.0), 4.5))
    counts_ax = fig.subplots()
    names = [Path(str(v)).name or f"job {j}" for v, j in zip(videos["video"], videos["job"])]
    x = np.arange(len(videos))
    counts_ax.bar(x, videos["vehicles"], color=["#9ecae1" if s == "done" else "#fcbba1" for s in videos["status"]])
    for i, status in enumerate(videos["status"]):
        if status != "done":
            counts_ax.text(i, 0.2, "failed", ha="center", va="bottom", color="#a50f15", rotation=90)
    counts_ax.set_ylabel("vehicles (bars)")
    counts_ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
    if len(tables.vehicles) and "speed_kmh" in tables.vehicles:
        speeds_ax = counts_ax.twinx()
        for i, job in enumerate(videos["job"]):
            speeds = tables.vehicles.loc[(tables.vehicles["job"] == job) & (tables.vehicles["status"] == "measured"),
                                         "speed_kmh"]
            speeds_ax.plot(np.full(len(speeds), i) + np.linspace(-0.25, 0.25, len(speeds)), speeds, "k.", ms=4)
        speeds_ax.set_ylabel("speed, km/h (dots)")
    counts_ax.set_title("vehloc-localize multirun: vehicles and speeds per video")
    fig.tight_layout()
    with atomic_path(path, ".png") as temporary:
        fig.savefig(temporary, dpi=110)
    return path


class MultirunTable(Callback):
    """Hydra callback of `vehloc-localize`: at the end of a multirun, the merged tables (`write_multirun_tables`),
    then the failed jobs and a non-zero exit when there are any."""

    def on_multirun_end(self, config: Any, **kwargs: Any) -> None:
        sweep_dir = Path(config.hydra.sweep.dir)
        tables = merge_localize_jobs(sweep_dir)
        write_multirun_tables(tables, sweep_dir)
        print(f"merged table of {len(tables.videos)} videos: {sweep_dir / (VIDEOS_STEM + '.md')}", flush=True)
        report_failed_jobs(sweep_dir, running_prog())
