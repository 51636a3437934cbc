"""Reading many autopilot parameters over a lossy link: all at once, each asked again on its timeout, within one
budget of wall time that every read of a run shares (``param_budget_s``, 60 s by default, counted from the first
request).

PARAM_REQUEST_READ by name; the answer is the PARAM_VALUE of that name, or, from recent firmware (and our
simulator), a PARAM_ERROR: DOES_NOT_EXIST says the firmware has no such parameter, which is an answer too.
Older firmware says nothing for a name it lacks, which cannot be told from a lost answer: then only the
budget ends the asking. At most ``WINDOW`` requests are outstanding at once (ArduPilot queues parameter
requests in a small buffer and drops what does not fit), so a burst never loses them by itself.

A request is a group of names that mean the same (``SYSID_MYGCS`` or ArduPilot 4.7's ``MAV_GCS_SYSID``): the
first that answers with a value settles it, and the others are no longer asked. A required group is asked
until it is settled or the budget is spent; an optional one ``OPTIONAL_TRIES`` times on a clean link, more on a
lossy one (``optional_tries``: the answer rate measured on the names answered so far), or for as long as a
required one is still being asked. Which parameters are which is the companion's business
(``mavbridge.companion.parameters``); this module only asks, listens and counts.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from mavbridge.link.retry import count_retry

OPTIONAL_TRIES = 3  # an optional name (older firmware lacking it sends nothing): asked this often at least
WINDOW = 8  # requests outstanding at once
OPTIONAL_MISS = 0.001  # an optional name the firmware has may go unread with at most this chance ...
OPTIONAL_MAX_TRIES = 25  # ... asked at most this often (50 % loss each way, p ≈ 0.25: the cap)
DOES_NOT_EXIST = 1  # MAV_PARAM_ERROR_DOES_NOT_EXIST
ERROR_NAMES = {1: "does not exist", 2: "value out of range", 3: "permission denied", 4: "component not found",
               5: "read only", 6: "type unsupported", 7: "type mismatch", 8: "read failed"}


@dataclass
class ParamBudget:
    """The wall seconds all parameter reads of a run may take together, counted from the first request."""

    total_s: float = 60.0
    started_s: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.total_s) and self.total_s > 0):
            raise ValueError(f"param_budget_s: {self.total_s!r} is outside the allowed range > 0 s")

    def start(self) -> None:
        """Start counting (once: later calls keep the first start)."""
        if self.started_s is None:
            self.started_s = time.monotonic()

    def left_s(self) -> float:
        """Seconds left (the whole budget before the first request)."""
        if self.started_s is None:
            return self.total_s
        return self.total_s - (time.monotonic() - self.started_s)


@dataclass(frozen=True)
class ParamRequest:
    """Names that mean the same parameter (the first to answer with a value settles it), and whether it is
    required (asked until settled or the budget is spent) or optional (while a required one is open, then
    ``optional_tries`` times)."""

    names: tuple[str, ...]
    required: bool = True


@dataclass
class ParamAnswers:
    """What the autopilot said: values by name, names it refused (PARAM_ERROR, by its reason), requests sent."""

    values: dict[str, float] = field(default_factory=dict)
    refused: dict[str, str] = field(default_factory=dict)
    tries: Counter = field(default_factory=Counter)

    def answered(self, name: str) -> bool:
        """True once ``name`` has a value or was refused."""
        return name in self.values or name in self.refused

    def settled(self, request: ParamRequest) -> bool:
        """A value for one of its names, or every name refused."""
        return any(n in self.values for n in request.names) or all(n in self.refused for n in request.names)

    def take(self, msg: Any) -> None:
        """Record a PARAM_VALUE or PARAM_ERROR."""
        name = str(msg.param_id)
        if msg.get_type() == "PARAM_VALUE":
            self.values[name] = float(msg.param_value)
            self.refused.pop(name, None)
        elif name not in self.values:
            self.refused[name] = ERROR_NAMES.get(int(msg.error), f"error {int(msg.error)}")


def optional_tries(answers: ParamAnswers) -> int:
    """How often to ask for an optional name before taking its silence as "the firmware has none": ``OPTIONAL_TRIES``
    on a clean link; on a lossy one until a name the firmware has would stay unanswered with a chance below
    ``OPTIONAL_MISS`` (at most ``OPTIONAL_MAX_TRIES``). That chance is (1 − p)ⁿ for a try answered with chance p,
    averaged over what the names answered so far say of p (k names in S tries: a Beta(k + 1, S − k + 1) belief
    from a uniform prior), E[(1 − p)ⁿ] = ∏ᵢ₌₀ⁿ⁻¹ (S − k + 1 + i) / (S + 2 + i): a few lucky answers do not
    shorten the asking as a single estimate of p would (40 % loss each way, p ≈ 0.36: about 18 tries)."""
    answered = [answers.tries[n] for n in (*answers.values, *answers.refused) if answers.tries[n] > 0]
    if not answered:
        return OPTIONAL_TRIES
    k, total = len(answered), sum(answered)
    miss, tries = 1.0, 0
    while tries < OPTIONAL_MAX_TRIES:
        miss *= (total - k + 1 + tries) / (total + 2 + tries)
        tries += 1
        if tries >= OPTIONAL_TRIES and miss <= OPTIONAL_MISS:
            break
    return tries


def _wanted(requests: list[ParamRequest], answers: ParamAnswers) -> list[str]:
    """The names to (keep) ask(ing), in order: those of unsettled groups not refused; an optional group's only
    while it has had fewer than ``optional_tries`` tries, or a required group is still unsettled."""
    required_open = any(r.required and not answers.settled(r) for r in requests)
    tries_optional = optional_tries(answers)
    names: list[str] = []
    for request in requests:
        if answers.settled(request):
            continue
        for name in request.names:
            if name in answers.refused or name in names:
                continue
            if request.required or required_open or answers.tries[name] < tries_optional:
                names.append(name)
    return names


class _Asking:
    """The requests in flight: when each name was last sent (wall clock)."""

    def __init__(self, link: Any, timeout_s: float, window: int) -> None:
        self.link, self.timeout_s, self.window = link, timeout_s, window
        self.sent_at: dict[str, float] = {}

    def in_flight(self, answers: ParamAnswers) -> list[str]:
        """The unanswered names whose last request has not timed out yet."""
        now = time.monotonic()
        return [n for n, at in self.sent_at.items() if now - at < self.timeout_s and not answers.answered(n)]

    def send_due(self, names: list[str], answers: ParamAnswers) -> None:
        """(Re)send the names not in flight, as far as the window allows; every resend is a counted retry."""
        flying = set(self.in_flight(answers))
        target = self.link.target
        for name in names:
            if len(flying) >= self.window:
                return
            if name in flying:
                continue
            if answers.tries[name]:
                count_retry(self.link.counts, "param")
            answers.tries[name] += 1
            self.sent_at[name] = time.monotonic()
            flying.add(name)
            self.link.send("param_request_read", target[0], target[1], name.encode(), -1)

    def next_expiry_s(self, answers: ParamAnswers) -> float:
        """Seconds until the earliest request in flight times out (the timeout if none is in flight)."""
        now = time.monotonic()
        return max(0.0, min((self.sent_at[n] + self.timeout_s - now for n in self.in_flight(answers)),
                            default=self.timeout_s))


Follow = Callable[[ParamAnswers], Iterable[ParamRequest]]


def read_parameters(link: Any, requests: Iterable[ParamRequest], budget: ParamBudget, timeout_s: float,
                    answers: ParamAnswers | None = None, follow: Follow | None = None,
                    window: int = WINDOW) -> ParamAnswers:
    """Ask for every request's names until each is settled (optional ones ``optional_tries`` times) or ``budget``
    is spent; ``timeout_s``: the wait for one answer before a name is asked again. ``follow(answers)``: requests
    that the answers so far call for (the RC calibration of the channels RCMAP names), asked as soon as they
    appear. Adds to ``answers`` when given. Link handlers keep running while it waits."""
    assert link.target is not None, "wait_autopilot() first"
    requests = list(requests)
    every = {name for request in requests for name in request.names}
    answers = answers if answers is not None else ParamAnswers()
    asking = _Asking(link, timeout_s, window)
    budget.start()

    def is_answer(msg: Any) -> bool:
        return (msg.get_type() in ("PARAM_VALUE", "PARAM_ERROR") and str(msg.param_id) in every
                and getattr(msg, "target_system", 0) in (0, link.system_id))

    while (left := budget.left_s()) > 0:
        for request in follow(answers) if follow is not None else ():
            if request not in requests:
                requests.append(request)
                every.update(request.names)
        names = _wanted(requests, answers)
        awaited = {n for r in requests if not answers.settled(r) for n in r.names} & set(asking.in_flight(answers))
        if not names and not awaited:  # (an optional name's last try may still be answered: awaited)
            break
        asking.send_due(names, answers)
        msg = link.wait_for(is_answer, min(left, max(0.01, asking.next_expiry_s(answers))))
        if msg is not None:
            answers.take(msg)
    return answers
