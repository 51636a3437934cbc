"""What of MAVSDK's own log reaches the operator: its errors (the only account of a fatal one), nothing else."""

from __future__ import annotations

import pytest
from mavsdk import LogLevel

from mission.transfer import _mavsdk_log_line


@pytest.mark.parametrize("level", [LogLevel.DEBUG, LogLevel.INFO, LogLevel.WARN])
def test_below_error_is_dropped(level: LogLevel, capsys: pytest.CaptureFixture[str]) -> None:
    assert _mavsdk_log_line(level, "New system on: 127.0.0.1:34334", None, 0) is True
    assert capsys.readouterr() == ("", "")


def test_errors_go_to_stderr_with_their_source_named(capsys: pytest.CaptureFixture[str]) -> None:
    text = "Mavsdk is being destroyed while things it handed out are still alive:"
    assert _mavsdk_log_line(LogLevel.ERROR, text, "mavsdk_impl.cpp", 120) is True  # MAVSDK prints nothing itself
    assert capsys.readouterr() == ("", f"MAVSDK error: {text}\n")
