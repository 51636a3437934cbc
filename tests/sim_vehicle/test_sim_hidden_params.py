"""`sim-vehicle --hide-params`: a parameter served as by an autopilot whose firmware lacks it (for the companion's
refusal tests), with PARAM_ERROR as recent ArduPilot answers, or nothing (``--no-param-error``) as older firmware."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess, sim_vehicle_command
from tests.waits import WaitTimeoutError, list_parameters, wait_for

pytestmark = pytest.mark.integration
DOES_NOT_EXIST = 1


def test_a_hidden_parameter_is_absent_from_the_list_and_reads_as_unknown(tmp_path: Path) -> None:
    with SimProcess(tmp_path, speedup=10, extra=["--hide-params", "RC3_TRIM,PILOT_STEER_TYPE"]) as sim:
        conn = sim.connect()
        listed = list_parameters(conn)
        assert "RC3_TRIM" not in listed and "PILOT_STEER_TYPE" not in listed and "RC3_MIN" in listed
        assert sorted(m.param_index for m in listed.values()) == list(range(len(listed)))  # no gap where it was
        conn.mav.param_request_read_send(1, 1, b"RC3_TRIM", -1)
        error = wait_for(conn, "PARAM_ERROR", 5, lambda m: m.param_id == "RC3_TRIM")
        assert error.error == DOES_NOT_EXIST
        conn.mav.param_set_send(1, 1, b"RC3_TRIM", 1600, 4)  # nor can it be set (it is not there)
        assert wait_for(conn, "PARAM_ERROR", 5, lambda m: m.param_id == "RC3_TRIM").error == DOES_NOT_EXIST
        conn.mav.param_request_read_send(1, 1, b"RC3_MIN", -1)
        assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "RC3_MIN").param_value == 1100


def test_without_param_error_an_unknown_name_gets_no_answer(tmp_path: Path) -> None:
    with SimProcess(tmp_path, speedup=10, extra=["--hide-params", "RC3_TRIM", "--no-param-error"]) as sim:
        conn = sim.connect()
        conn.mav.param_request_read_send(1, 1, b"RC3_TRIM", -1)
        conn.mav.param_request_read_send(1, 1, b"NO_SUCH_PARAM", -1)
        conn.mav.param_request_read_send(1, 1, b"RC3_DZ", -1)  # sent last: once it is answered, the others were read
        assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "RC3_DZ").param_value == 30
        with pytest.raises(WaitTimeoutError):  # (the simulator answers within a step: 1 s is 10 s simulated)
            wait_for(conn, ["PARAM_ERROR", "PARAM_VALUE"], 1.0, lambda m: m.param_id in ("RC3_TRIM", "NO_SUCH_PARAM"))


def test_hiding_an_unknown_name_is_one_line_and_exit_2(tmp_path: Path) -> None:
    done = subprocess.run([*sim_vehicle_command(), "--hide-params", "RC9_NOPE", "--no-out", "--no-tcp",
                           "--params-store", str(tmp_path / "p.json")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["sim-vehicle: error: --hide-params: RC9_NOPE is not a parameter of "
                                                "this simulator"]
