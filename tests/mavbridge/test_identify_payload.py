"""The payload fit (issue 50): a hull faster than the published model because it carries more payload (whose
weight the published model's load term counts a second time) is identified by its payload, not by max_speed; a
hull the payload does not explain keeps max_speed, and a published hull gets neither."""

from __future__ import annotations

import math
from typing import Any

import pytest

from mavbridge.identify.analyse import Identification
from mavbridge.identify.commands import identify
from mavbridge.identify.estimate import Estimate
from mavbridge.identify.logdata import read_log
from mavbridge.identify.model import plant_speed, plant_steady
from mavbridge.identify.outputs import MIN_SURGE_R2, unfit_lines, vessel_fields
from mavbridge.identify.payload import fit_payload, runaway_mass
from mavbridge.identify.surge import SurgePoint
from tests.mavbridge.identify_logs import write_identify_log
from vessel import OtterParameters, otter_parameters

PUBLISHED = otter_parameters("published")
HULLS = {"45 kg": PUBLISHED.replace(payload_mass=45.0),
         "published": PUBLISHED,
         "60 kg once": PUBLISHED.replace(payload_mass=60.0, payload_load_term=False)}


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Identification, dict[str, Any]]]:
    """Each hull's 600 s log identified on the published base: (identification, vessel fields)."""
    out = {}
    for name, hull in HULLS.items():
        path = tmp_path_factory.mktemp("payload") / "otter.csv"
        write_identify_log(path, hull, 600, seed=3)
        result = identify([read_log(path)], PUBLISHED)
        out[name] = (result, vessel_fields(PUBLISHED, result))
    return out


def test_a_45_kg_hull_gives_its_payload_and_the_model_its_speeds(identified: dict) -> None:
    result, fields = identified["45 kg"]
    estimate = result.estimates["payload_mass_kg"]
    assert fields["payload_mass"] == pytest.approx(45.0, abs=1.5)
    assert estimate.low <= fields["payload_mass"] <= estimate.high and estimate.unit == "kg"
    assert "max_speed" not in fields  # the payload explains the speeds: the surge damping stays the base's
    model = PUBLISHED.replace(**fields)
    for output in (0.5, 1.0):
        hull_speed, model_speed = plant_speed(HULLS["45 kg"], output), plant_speed(model, output)
        assert hull_speed is not None and model_speed is not None
        assert model_speed == pytest.approx(hull_speed, rel=0.05)


def test_a_published_hull_writes_no_payload(identified: dict) -> None:
    result, fields = identified["published"]
    assert "payload_mass" not in fields
    assert result.estimates["payload_mass_kg"].value == pytest.approx(PUBLISHED.payload_mass, abs=1.5)
    assert any(line.startswith("payload_mass_kg") for line in unfit_lines(result))


def test_a_hull_the_payload_does_not_explain_keeps_max_speed(identified: dict) -> None:
    """60 kg whose weight counts once floats level and is slower than the published model: the fit wants no
    payload at all (where a lighter payload would still trim the bow down, which the log's pitch does not show),
    and max_speed is fitted as before, with one line saying why."""
    result, fields = identified["60 kg once"]
    assert "payload_mass" not in fields and "max_speed" in fields
    lines = [line for line in unfit_lines(result) if line.startswith("payload_mass_kg")]
    assert len(lines) == 1 and "max_speed is fitted instead" in lines[0]


def test_no_payload_is_fitted_on_a_base_without_the_load_term(identified: dict) -> None:
    result, _ = identified["45 kg"]
    assert fit_payload(PUBLISHED.replace(payload_load_term=False), result) is None


def test_the_fit_stays_below_the_mass_at_which_the_model_runs_away() -> None:
    """The published model runs away at full command with 60 kg and settles with 45 kg (see
    tests/vessel/test_payload_load_runaway.py): the bound lies between."""
    limit = runaway_mass(PUBLISHED)
    assert 45.0 < limit < 60.0
    assert runaway_mass(PUBLISHED.replace(payload_load_term=False)) > limit



def _steady_windows(hull: OtterParameters, pitch_offset_rad: float) -> Identification:
    """Three steady windows at each of two commands (thrust fractions 0.09, 0.36) at the hull's own steady speed
    and pitch (the latter shifted by ``pitch_offset_rad``)."""
    points = []
    for fraction in (0.09, 0.36):
        got = plant_steady(hull, math.sqrt(fraction))
        assert got is not None
        points += [SurgePoint(float(k), math.sqrt(fraction), fraction, got[0], got[1] + pitch_offset_rad)
                   for k in range(3)]
    return Identification(surge={"points": points})


def test_the_payload_is_refused_where_the_model_would_trim_otherwise_than_the_log() -> None:
    hull = HULLS["45 kg"]
    level = fit_payload(PUBLISHED, _steady_windows(hull, 0.0))
    assert level is not None and level.chosen and level.estimate.value == pytest.approx(45.0, abs=0.5)
    off = fit_payload(PUBLISHED, _steady_windows(hull, math.radians(1.0)))  # the log floats a degree nearer level
    assert off is not None and not off.chosen and "trim" in off.why_not


def test_a_speed_not_linear_in_the_thrust_writes_no_payload() -> None:
    """The real Otter's case: the speed fit's R² below MIN_SURGE_R2 puts no surge field into vessel.yaml, and no
    payload is fitted in its place, however the windows look."""
    result = _steady_windows(HULLS["45 kg"], 0.0)
    result.estimates["surge_speed_full_forward_m_s"] = Estimate(3.7, 3.6, 3.8, "m/s", "windows",
                                                                MIN_SURGE_R2 - 0.3)
    fields = vessel_fields(PUBLISHED, result)
    assert "payload_mass" not in fields and "max_speed" not in fields
    assert "payload_mass_kg" not in result.estimates
    good = _steady_windows(HULLS["45 kg"], 0.0)
    good.estimates["surge_speed_full_forward_m_s"] = Estimate(3.7, 3.6, 3.8, "m/s", "windows", 0.99)
    assert vessel_fields(PUBLISHED, good)["payload_mass"] == pytest.approx(45.0, abs=0.5)  # the same, well fitted


def test_the_pages_surge_curve_is_the_models_own_with_the_payload(identified: dict) -> None:
    """The page draws each model's steady speeds measured on the plant, not u = max_speed·s: with the payload
    identified (max_speed unchanged) the identified curve is the 45 kg hull's, above the base's."""
    from mavbridge.identify.figures import model_speed_curve, surge_figure

    result, fields = identified["45 kg"]
    fractions, speeds = model_speed_curve(PUBLISHED.replace(**fields))
    _, base_speeds = model_speed_curve(PUBLISHED)
    assert fractions[-1] == 1.0 and speeds[-1] == pytest.approx(plant_speed(HULLS["45 kg"], 1.0), rel=0.05)
    assert speeds[-1] > 1.05 * base_speeds[-1]
    assert surge_figure(result, PUBLISHED, PUBLISHED.replace(**fields)).startswith(b"\x89PNG")


def test_a_payload_without_an_interval_is_refused_with_its_line() -> None:
    """An interval of nan (the model's speeds flat in the mass, or running away beside it) holds nothing against
    the base's mass: refused, not taken for one that leaves it out."""
    from mavbridge.identify.payload import _why_not

    why = _why_not(PUBLISHED, 45.0, (math.nan, math.nan), 50.0, 0.003, 0.14, 0.0)
    assert "no interval" in why and "max_speed is fitted instead" in why
    assert _why_not(PUBLISHED, 45.0, (44.5, 45.5), 50.0, 0.003, 0.14, 0.0) == ""


def test_one_steady_command_says_the_payload_was_not_tried() -> None:
    """A log with steady forward windows at one command only (a real boat run at one throttle): max_speed as
    before, and one line saying why no payload."""
    from mavbridge.identify.outputs import surge_and_payload

    two = _steady_windows(HULLS["45 kg"], 0.0)
    one = Identification(surge={"points": [p for p in two.surge["points"] if p.fraction > 0.2]})
    one.estimates["surge_speed_full_forward_m_s"] = Estimate(3.9, 3.8, 4.0, "m/s", "windows", 0.99)
    fields = surge_and_payload(PUBLISHED, one, {})
    assert "payload_mass" not in fields and "max_speed" in fields
    assert "two commands" in one.surge["payload_not_used"]
    assert any("two commands" in line for line in unfit_lines(one))


def test_a_day_of_commands_is_merged_into_a_few_levels() -> None:
    """An hour's log holds dozens of steady commands; the fit flies the model at each level for every mass it
    tries, so more than MAX_LEVELS are merged (in order, by their windows' mean fraction), fewer are kept as they
    are."""
    from mavbridge.identify.payload import MAX_LEVELS, forward_levels

    many = [SurgePoint(float(k), 0.0, 0.05 + 0.01 * k, 0.5 + 0.02 * k, -0.01) for k in range(40)]
    levels = forward_levels(Identification(surge={"points": many}))
    assert len(levels) == MAX_LEVELS
    assert [v.fraction for v in levels] == sorted(v.fraction for v in levels)
    assert sum(len(v.speeds) for v in levels) == len(many)
    few = forward_levels(Identification(surge={"points": many[:3]}))
    assert [v.fraction for v in few] == [0.05, 0.06, 0.07]
