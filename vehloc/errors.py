"""Errors that vehloc reports to users as one clear line and a non-zero exit, and the console scripts' way of
ending: `<prog>: error: <what is wrong>` and exit code 1 for bad input, `<prog>: interrupted` and exit code
130 for Ctrl-C, never a traceback for either."""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any

INTERRUPTED_EXIT_CODE = 130
"""The shell's code for a process ended by SIGINT (128 + 2)."""
_running_prog = "vehloc"


def running_prog() -> str:
    """The console script this process runs (`hydra_main` sets it), for lines written outside its task."""
    return _running_prog


class VehlocError(Exception):
    """A user-facing error: bad input, missing file, inconsistent data."""


class DataError(VehlocError):
    """A data set or table is missing, malformed or inconsistent.

    `problems` lists every problem found, each naming the file (and line) and what is wrong.
    """

    def __init__(self, summary: str, problems: Sequence[str] = ()) -> None:
        self.summary = summary
        self.problems = list(problems)
        lines = [summary] + [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


def _report(prog: str, message: str) -> None:
    sys.stdout.flush()
    print(f"{prog}: {message}", file=sys.stderr, flush=True)


def _fail(prog: str, message: str) -> None:
    """Report a failure in one line and exit 1; in a Hydra multirun job, record it in the job's folder and return,
    so that the other jobs run (`vehloc.multirun` lists the failed ones at the end and exits non-zero)."""
    from vehloc.multirun import multirun_job_dir, record_job_failure

    job_dir = multirun_job_dir()
    if job_dir is None:
        _report(prog, f"error: {message}")
        raise SystemExit(1) from None
    _report(prog, f"error: job {job_dir.name}: {message}")
    record_job_failure(job_dir, message.splitlines()[0])


def os_error_line(exc: OSError) -> str:
    """`<file>: <what the system said>` for an OSError about a file (a read-only file system), or what the system
    said alone when it names no file (a full disk while a library writes)."""
    said = exc.strerror or str(exc) or type(exc).__name__
    return f"{exc.filename}: {said}" if exc.filename else f"{said} (errno {exc.errno})" if exc.errno else said


def exit_on_error(prog: str):
    """Decorate a console-script main: a VehlocError becomes its message on stderr and exit code 1, as does an
    OSError (the file and the system's reason, or the reason alone where it names no file); in a multirun job
    either becomes a record of the failure instead (`_fail`); Ctrl-C (KeyboardInterrupt) becomes
    `<prog>: interrupted` and exit code 130."""

    def decorate(main):
        @functools.wraps(main)
        def wrapper(*args, **kwargs):
            try:
                return main(*args, **kwargs)
            except VehlocError as exc:
                _fail(prog, str(exc))
            except OSError as exc:
                _fail(prog, os_error_line(exc))
            except KeyboardInterrupt:
                _report(prog, "interrupted")
                raise SystemExit(INTERRUPTED_EXIT_CODE) from None

        return wrapper

    return decorate


def hydra_error_line(exc: BaseException) -> str:
    """One line for an error Hydra or OmegaConf raises while composing a config (an unknown key, a malformed
    override, a missing config group option) or while preparing the run folder."""
    from hydra.errors import MissingConfigException
    from omegaconf.errors import OmegaConfBaseException

    missing = re.search(r"Missing mandatory value: ([\w.]+)", str(exc))
    if missing:
        return f"{missing.group(1)}=... is required (it has no value)"
    if isinstance(exc, OSError) and exc.filename and not isinstance(exc, MissingConfigException):
        if isinstance(exc, FileExistsError):
            return f"{exc.filename}: exists and is not a folder; the run's outputs need a folder there"
        return f"{exc.filename}: cannot create the run folder or write into it ({exc.strerror})"
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    message = lines[0].rstrip(".") if lines else type(exc).__name__
    if isinstance(exc, MissingConfigException) and exc.options:
        message += f" (options: {', '.join(exc.options)})"
    cause = exc.__cause__
    if isinstance(cause, OmegaConfBaseException):
        cause_lines = [line.strip() for line in str(cause).splitlines() if line.strip()]
        if cause_lines and cause_lines[0] not in message:
            message += f": {cause_lines[0]}"
        if "is not in struct" in message:
            message += " (no such setting)"
    elif not isinstance(exc, MissingConfigException) and len(lines) > 1 and not lines[1].startswith(("^", "$")):
        message += f": {lines[1]}"
    return message


def hydra_main(prog: str, config_path: str, config_name: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """`hydra.main` for a console script whose Hydra errors end like vehloc's own: a bad override, an unknown
    key or config option, a run folder that cannot be created each give `<prog>: error: ...` in one line and
    exit code 1; Ctrl-C while Hydra composes gives `<prog>: interrupted` and 130. The task function should
    itself be decorated with `exit_on_error(prog)`. With HYDRA_FULL_ERROR=1 set by the user, Hydra's own
    reports are kept."""

    def decorate(task: Callable[..., Any]) -> Callable[..., Any]:
        import hydra

        hydra_task = hydra.main(version_base="1.3", config_path=config_path, config_name=config_name)(task)

        @functools.wraps(hydra_task)
        def wrapper(*args, **kwargs):
            from hydra.errors import HydraException
            from omegaconf.errors import OmegaConfBaseException

            global _running_prog
            _running_prog = prog
            user_wants_traces = os.environ.get("HYDRA_FULL_ERROR") == "1"
            os.environ["HYDRA_FULL_ERROR"] = "1"  # Hydra raises instead of printing its report, so it ends here
            try:
                return hydra_task(*args, **kwargs)
            except (HydraException, OmegaConfBaseException, OSError) as exc:
                if user_wants_traces:
                    raise
                _report(prog, f"error: {hydra_error_line(exc)}")
                raise SystemExit(1) from None
            except ValueError as exc:  # logging's "Unable to configure handler": the run folder's log cannot be written
                cause = exc.__cause__ or exc.__context__
                if user_wants_traces or not (isinstance(cause, OSError) and cause.filename):
                    raise
                _report(prog, f"error: {cause.filename}: cannot write the run's log there "
                              f"({cause.strerror or type(cause).__name__})")
                raise SystemExit(1) from None
            except KeyboardInterrupt:
                _report(prog, "interrupted")
                raise SystemExit(INTERRUPTED_EXIT_CODE) from None
            finally:
                if not user_wants_traces:
                    os.environ.pop("HYDRA_FULL_ERROR", None)

        return wrapper

    return decorate
