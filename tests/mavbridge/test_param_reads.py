"""How often an optional parameter is asked for before its silence is taken as "the firmware has none": as before
on a clean link, more on a lossy one, from the answer rate the reads so far measured."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from mavbridge.link.param_reads import (
    OPTIONAL_MAX_TRIES,
    OPTIONAL_MISS,
    OPTIONAL_TRIES,
    ParamAnswers,
    ParamRequest,
    _wanted,
    optional_tries,
)


def _answers(tries_of_answered: list[int], refused: int = 0) -> ParamAnswers:
    """Names P0.. answered with a value after the given numbers of tries, and ``refused`` names refused at once."""
    values = {f"P{i}": 1.0 for i in range(len(tries_of_answered))}
    tries = Counter({f"P{i}": n for i, n in enumerate(tries_of_answered)})
    refusals = {f"R{i}": "does not exist" for i in range(refused)}
    tries.update({name: 1 for name in refusals})
    return ParamAnswers(values=values, refused=refusals, tries=tries)


def test_a_clean_link_asks_an_optional_name_as_often_as_before() -> None:
    assert optional_tries(ParamAnswers()) == OPTIONAL_TRIES  # nothing measured yet
    assert optional_tries(_answers([1] * 17, refused=2)) == OPTIONAL_TRIES  # every try answered (19 names)


def _expected_miss(k: int, total: int, n: int) -> float:
    """E[(1 − p)ⁿ] under the Beta(k + 1, total − k + 1) belief about p, by numerical integration (not the product
    the code uses)."""
    p = np.linspace(0.0, 1.0, 200_001)
    density = p**k * (1 - p) ** (total - k)
    integrate = getattr(np, "trapezoid", None) or np.trapz  # numpy >= 2 renamed it; the project allows 1.26
    return float(integrate(density * (1 - p) ** n, p) / integrate(density, p))


def test_a_lossy_link_asks_until_a_lost_answer_is_unlikely() -> None:
    """At 40 % loss each way a try is answered with p ≈ 0.36 (12 names in 33 tries): an optional name is asked
    until a name the firmware has would stay unanswered with a chance (averaged over what 12 names say of p) below
    OPTIONAL_MISS; more than a single estimate of p would ask (16, which by the averaged belief still leave 0.26 %)."""
    lossy = _answers([2, 3, 4, 2, 3, 3, 2, 3, 3, 2, 3, 3])  # 33 tries for 12 answers
    n = optional_tries(lossy)
    assert OPTIONAL_TRIES < n < OPTIONAL_MAX_TRIES
    assert _expected_miss(12, 33, n) <= OPTIONAL_MISS < _expected_miss(12, 33, n - 1)
    assert math.ceil(math.log(OPTIONAL_MISS) / math.log(1 - 12 / 33)) < n  # what a single estimate of p asks
    assert optional_tries(_answers([50] * 4)) == OPTIONAL_MAX_TRIES  # a nearly dead link: capped


def test_two_lucky_answers_are_not_a_clean_link() -> None:
    """Two names answered at the first try say little of the link: asked more than on a link 19 names vouch for."""
    assert optional_tries(_answers([1, 1])) > optional_tries(_answers([1] * 19)) == OPTIONAL_TRIES


def test_the_optional_name_stays_wanted_until_its_tries_are_spent() -> None:
    """With every required name settled, the optional one is asked again on a lossy link after OPTIONAL_TRIES
    unanswered tries (it would have been given up before), and given up after ``optional_tries``."""
    answers = _answers([2, 3, 4, 2, 3, 3, 2, 3, 3, 2, 3, 3])
    requests = [ParamRequest(("P0",)), ParamRequest(("RC_OPTIONS",), required=False)]
    answers.tries["RC_OPTIONS"] = OPTIONAL_TRIES
    assert _wanted(requests, answers) == ["RC_OPTIONS"]
    answers.tries["RC_OPTIONS"] = optional_tries(answers)
    assert _wanted(requests, answers) == []
