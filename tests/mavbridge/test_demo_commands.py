"""`mavbridge demo`'s flags reach its children: --seed the simulator, --direct the companion's scenario (R = 0)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from mavbridge.cli import main
from mavbridge.cli.run import demo_scenario
from mavbridge.lab.demo import demo_commands, write_resolved
from mavbridge.lab.scenario import Scenario


def _value_after(cmd: list[str], flag: str) -> str:
    return cmd[cmd.index(flag) + 1]


def test_seed_goes_to_the_simulator_only(tmp_path: Path) -> None:
    scenario = Scenario(name="balanced")
    resolved = str(write_resolved(scenario, tmp_path))
    sim, companion = demo_commands(scenario, tmp_path, resolved, (1, 2, 3), 10.0, "rc_override", "estimated",
                                   True, seed=7)
    assert _value_after(sim, "--seed") == "7" and "--seed" not in companion
    fresh, _ = demo_commands(scenario, tmp_path, resolved, (1, 2, 3), 10.0, "rc_override", "estimated", True)
    assert "--seed" not in fresh  # the simulator draws a fresh seed and prints it


def test_direct_flies_the_same_scenario_with_r_zero(tmp_path: Path) -> None:
    balanced = demo_scenario(None, None, direct=False)
    direct = demo_scenario(None, None, direct=True)
    assert balanced.controller.r > 0 and direct.controller.r == 0.0
    assert direct.controller.q == balanced.controller.q and direct.sea == balanced.sea
    written = yaml.safe_load(write_resolved(direct, tmp_path).read_text())  # what both children read
    assert float(written["controller"]["r"]) == 0.0


@pytest.mark.parametrize("seed", ["-1", "4294967296", "1.5", "nan"])
def test_bad_seed_is_one_line_and_exit_2(seed: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["demo", "--seed", seed])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--seed" in err[-1] and "Traceback" not in "\n".join(err)
