"""A refused value in the companion's YAML (issue 35): one line naming the file, the key, the allowed range
and what to do; exit 2, no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mavbridge.companion.config import load_companion_config
from vessel.config import ConfigError


@pytest.mark.parametrize(("line", "expected"), [
    ("baud: -5", "baud: -5 is outside the allowed range [1200, 4e+06] baud; correct baud in {f}, or delete the "
                 "line to use its default (921600)"),
    ("output: rc", "output: 'rc' is not one of rc_override, attitude_target; correct output in {f}, or delete the "
                   "line to use its default ('rc_override')"),
    ("wave_roll_sign: 0.5", "wave_roll_sign: 0.5 is not one of -1, 1; correct wave_roll_sign in {f}, or delete the "
                            "line to use its default (1.0)"),
    ("max_time_s: -1", "max_time_s: -1 is outside the allowed range [0.1, 1e+06] s; correct max_time_s in {f}, or "
                       "delete the line to use its default (none)"),
    ("bogus: 1", "unknown key 'bogus' (allowed: attitude_form,"),
])
def test_a_refused_value_names_file_key_range_and_fix(tmp_path: Path, line: str, expected: str) -> None:
    config = tmp_path / "companion.yaml"
    config.write_text(f"# a deployer's file\n{line}\n")
    with pytest.raises(ConfigError) as caught:
        load_companion_config(config)
    assert str(caught.value).startswith(f"{config}: " + expected.format(f=config)), caught.value


def test_the_command_line_says_it_in_one_line_with_exit_2(tmp_path: Path) -> None:
    config = tmp_path / "companion.yaml"
    config.write_text("connect: /dev/ttyAMA0\nlink_timeout_s: 0\n")
    done = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--config", str(config), "--dry-run",
                           "--waypoint", "10,10"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith(f"mavbridge: error: --config: {config}: link_timeout_s: 0 is outside the allowed "
                               "range"), lines[0]
    assert f"correct link_timeout_s in {config}, or delete the line to use its default (2.0)" in lines[0]
