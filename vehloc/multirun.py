"""A Hydra multirun (`-m`, on any launcher: joblib, SLURM, Ray) where one bad job never ends the others: a job's
failure becomes a record in its own folder (`job_error.txt`, the one line it printed), the other jobs run on, and
at the end the failed jobs are listed with their overrides and reasons and the command exits non-zero."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback

JOB_ERROR_FILE = "job_error.txt"
FAILED_JOBS_EXIT_CODE = 1


@dataclass(frozen=True)
class JobFolder:
    """One job of a multirun: its number, folder, overrides and, when it failed, the reason."""

    number: int
    path: Path
    overrides: tuple[str, ...]
    error: str | None

    @property
    def label(self) -> str:
        return f"job {self.number} ({' '.join(self.overrides) or 'no overrides'})"


def multirun_job_dir() -> Path | None:
    """The output folder of the Hydra multirun job this runs in, or None outside one."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    if not HydraConfig.initialized():
        return None
    hydra_config = HydraConfig.get()
    if hydra_config.mode != RunMode.MULTIRUN:
        return None
    return Path(hydra_config.runtime.output_dir)


def record_job_failure(job_dir: Path, line: str) -> None:
    """Write the line a failed job printed into its folder (where `job_folders` finds it)."""
    from vehloc.atomic import write_text

    job_dir.mkdir(parents=True, exist_ok=True)
    write_text(job_dir / JOB_ERROR_FILE, line + "\n")


def job_folders(sweep_dir: Path) -> list[JobFolder]:
    """The jobs of a multirun folder (each a numbered sub-folder with Hydra's `.hydra/overrides.yaml`), in order."""
    import yaml

    jobs = []
    for path in sorted((p for p in Path(sweep_dir).iterdir() if p.is_dir() and p.name.isdigit()), key=lambda p: int(p.name)):
        overrides_file = path / ".hydra" / "overrides.yaml"
        overrides = yaml.safe_load(overrides_file.read_text()) if overrides_file.is_file() else []
        error_file = path / JOB_ERROR_FILE
        error = error_file.read_text(encoding="utf-8").strip() if error_file.is_file() else None
        jobs.append(JobFolder(int(path.name), path, tuple(overrides or ()), error))
    return jobs


def report_failed_jobs(sweep_dir: Path, prog: str) -> None:
    """After a multirun: list its failed jobs on stderr and exit with FAILED_JOBS_EXIT_CODE when there are any."""
    jobs = job_folders(sweep_dir)
    failed = [job for job in jobs if job.error is not None]
    if not failed:
        return
    sys.stdout.flush()
    lines = [f"{prog}: error: {len(failed)} of {len(jobs)} jobs failed (the others ran to the end; {sweep_dir}):"]
    lines += [f"  {job.label}: {job.error}" for job in failed]
    print("\n".join(lines), file=sys.stderr, flush=True)
    raise SystemExit(FAILED_JOBS_EXIT_CODE)


class ReportFailedJobs(Callback):
    """Hydra callback: at the end of a multirun, the failed jobs and a non-zero exit (`report_failed_jobs`)."""

    def on_multirun_end(self, config: Any, **kwargs: Any) -> None:
        from vehloc.errors import running_prog

        report_failed_jobs(Path(config.hydra.sweep.dir), running_prog())
