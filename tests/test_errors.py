"""The console scripts' way of ending on an error: one line and exit code 1, for an OSError that names no file too
(a full disk while a library writes), and in a multirun job a record in the job's folder instead of an exit."""

from __future__ import annotations

import errno

import pytest

from vehloc.errors import VehlocError, exit_on_error


def test_an_os_error_without_a_file_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    @exit_on_error("vehloc-x")
    def writes_on_a_full_disk() -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(SystemExit) as ended:
        writes_on_a_full_disk()
    assert ended.value.code == 1
    assert capsys.readouterr().err == f"vehloc-x: error: No space left on device (errno {errno.ENOSPC})\n"


def test_an_os_error_about_a_file_names_it(capsys: pytest.CaptureFixture[str]) -> None:
    @exit_on_error("vehloc-x")
    def writes_on_a_read_only_folder() -> None:
        raise PermissionError(errno.EACCES, "Permission denied", "/data/out.csv")

    with pytest.raises(SystemExit):
        writes_on_a_read_only_folder()
    assert capsys.readouterr().err == "vehloc-x: error: /data/out.csv: Permission denied\n"


def test_a_vehloc_error_outside_a_multirun_ends_the_run(capsys: pytest.CaptureFixture[str]) -> None:
    @exit_on_error("vehloc-x")
    def refuses() -> None:
        raise VehlocError("video.avi: not a readable video")

    with pytest.raises(SystemExit) as ended:
        refuses()
    assert ended.value.code == 1 and capsys.readouterr().err == "vehloc-x: error: video.avi: not a readable video\n"
