"""The autopilot parameters that decide the companion's commands: which they are for each output, reading them
all before it engages within one budget, and the one line that refuses to engage when one stays unread.

Never assumed: what turns the NMPC's forces into RC PWM (RCMAP_ROLL/THROTTLE, the mapped channels'
RCn_MIN/TRIM/MAX/DZ/REVERSED, PILOT_STEER_TYPE), the skid mixer those commands pass through (SERVO1/3_FUNCTION,
FRAME_CLASS), whose overrides the autopilot obeys (SYSID_MYGCS, or 4.7's MAV_GCS_SYSID), what scales GUIDED's
thrust (WP_SPEED, CRUISE_SPEED) and the gains the tau form inverts (``guided.inverse.LOOP_PARAMETERS``). Each is
asked for again every ``command_timeout_s`` until it answers, all of them together within ``param_budget_s``
(``mavbridge.link.param_reads``); one still unread then is named in one line and nothing else is sent. A
parameter the autopilot says it has no such thing of (PARAM_ERROR) is a refusal too, unless ``OPTIONAL`` says
what the firmware then does. ``OPTIONAL`` is the one place that lists what the companion may go without, and
why; `mavbridge check` judges with the same reads and the same ``engage_problem`` (and reads more for its own
findings: failsafes, WP_RADIUS, stream rates, which decide nothing the companion sends).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from mavbridge.companion.guided.feedback import ASYM, MOTOR_PARAMETERS
from mavbridge.companion.guided.inverse import (
    BRAKE,
    LOOP_PARAMETERS,
    OPTIONAL_LOOP_PARAMETERS,
    RoverLoops,
    default_speed,
)
from mavbridge.companion.outputs import RcCalibration, RcSetup
from mavbridge.link.connection import LinkError
from mavbridge.link.param_reads import ParamAnswers, ParamRequest, read_parameters
from mavbridge.preflight.rules import Context, enforced_violations
from vessel.wording import counted

GCS_ID = ("SYSID_MYGCS", "MAV_GCS_SYSID")  # the same parameter: ArduPilot 4.7 renamed it
SKID_MIXER = ("FRAME_CLASS", "SERVO1_FUNCTION", "SERVO3_FUNCTION")
RC_INPUTS = ("RCMAP_ROLL", "RCMAP_THROTTLE", "PILOT_STEER_TYPE")
CALIBRATION = ("MIN", "TRIM", "MAX", "DZ", "REVERSED")
GUIDED_SPEED = ("WP_SPEED", "CRUISE_SPEED")


@dataclass(frozen=True)
class Leeway:
    """How far the companion may go without one parameter, and why: ``unread_ok`` (it changes nothing the
    companion sends, so it may stay unread), ``if_absent`` (the value Rover behaves as when the autopilot says it
    has no such parameter; None: then it is a refusal too)."""

    reason: str
    unread_ok: bool = False
    if_absent: float | None = None


OPTIONAL: dict[str, Leeway] = {  # the one list of what the companion may go without
    "RC_OVERRIDE_TIME": Leeway("how long the autopilot keeps an override, not what it commands; `mavbridge check` "
                               "judges it, and the companion refuses 0 (overrides ignored) when it reads it",
                               unread_ok=True),
    "RC_OPTIONS": Leeway("whether the autopilot ignores overrides (bit 1), not what they command; `mavbridge check` "
                         "judges it, and the companion refuses the bit when it reads it", unread_ok=True),
    BRAKE: Leeway("whether Rover's speed loop may reverse while the target is ahead: a warning that the plan's "
                  "braking is lost, not an input of the tau form's targets", unread_ok=True),
    "ATC_SPEED_FF": Leeway("the tau form adds it to the speed feed-forward; firmware without it behaves as 0",
                           if_absent=0.0),
    "ATC_SPEED_D": Leeway("the tau form needs it 0; firmware without it has no D term", if_absent=0.0),
    "ATC_STR_RAT_D": Leeway("the tau form needs it 0; firmware without it has no D term", if_absent=0.0),
    ASYM: Leeway("the tau form's output feedback undoes it on reverse outputs; firmware without it has none (1)",
                 if_absent=1.0),
}


def _request(name: str) -> ParamRequest:
    leeway = OPTIONAL.get(name)
    return ParamRequest((name,), required=leeway is None or not leeway.unread_ok)


def first_round(output: str, attitude_form: str | None) -> list[ParamRequest]:
    """What ``output`` (in ``attitude_form``) depends on, but the RC calibration (whose channels RCMAP names)."""
    if output == "rc_override":
        names = [*RC_INPUTS, *SKID_MIXER, "RC_OVERRIDE_TIME", "RC_OPTIONS"]
        return [ParamRequest(GCS_ID), *(_request(n) for n in names)]
    names = ["FRAME_CLASS", *GUIDED_SPEED]
    if attitude_form == "tau":  # the targets are the skid mixer's inverse through Rover's loops, seen at the motors
        names += [*SKID_MIXER, *LOOP_PARAMETERS, *OPTIONAL_LOOP_PARAMETERS, BRAKE, *MOTOR_PARAMETERS, ASYM]
    return [_request(n) for n in dict.fromkeys(names)]


def rc_channels(values: dict[str, float]) -> tuple[int, int] | None:
    """(steering, throttle) input channels from RCMAP_ROLL/RCMAP_THROTTLE; None while either is unread or they
    are not two distinct channels in 1..8 (which ``rc_setup`` refuses, naming them)."""
    if "RCMAP_ROLL" not in values or "RCMAP_THROTTLE" not in values:
        return None
    steer, throttle = round(values["RCMAP_ROLL"]), round(values["RCMAP_THROTTLE"])
    return (steer, throttle) if steer != throttle and 1 <= min(steer, throttle) <= max(steer, throttle) <= 8 else None


def second_round(output: str, values: dict[str, float]) -> list[ParamRequest]:
    """The calibration of the RC inputs RCMAP named (rc_override only; none while RCMAP is unread)."""
    channels = rc_channels(values) if output == "rc_override" else None
    if channels is None:
        return []
    return [_request(f"RC{ch}_{suffix}") for ch in dict.fromkeys(channels) for suffix in CALIBRATION]


@dataclass(frozen=True)
class CommandParameters:
    """The values read (by name), the refusal line if a needed one is missing, and what the reading took."""

    values: dict[str, float]
    names: tuple[str, ...]  # every name asked for
    refusal: str | None
    absent: tuple[str, ...]  # the autopilot has none of these: ``OPTIONAL``'s if_absent applies
    unread: tuple[str, ...]  # optional ones that did not answer (they change nothing sent)
    requests: int
    seconds: float

    def summary(self) -> str:
        """'19 parameters read in 2.1 s (25 requests)', for the start's log line."""
        return (f"{counted(len(self.values), 'parameter')} read in {self.seconds:.1f} s "
                f"({counted(self.requests, 'request')})")


def _refused(request: ParamRequest, answers: ParamAnswers) -> str | None:
    """Why a required request that the autopilot answered has no usable value (None: it has one, or it is absent
    and ``OPTIONAL`` says what the firmware then does, or it was not answered at all)."""
    if not request.required or any(n in answers.values for n in request.names):
        return None
    if not all(n in answers.refused for n in request.names):
        return None  # (not answered: ``_unread``)
    if all(answers.refused[n] == "does not exist" and OPTIONAL.get(n, Leeway("")).if_absent is not None
           for n in request.names):
        return None
    if len(request.names) > 1:
        return f"the autopilot has neither {' nor '.join(request.names)}"
    name, reason = request.names[0], answers.refused[request.names[0]]
    return f"the autopilot has no {name}" if reason == "does not exist" else f"{name}: the autopilot says {reason}"


def _unread(request: ParamRequest, answers: ParamAnswers) -> str | None:
    """The name of a required request no answer came for (None: answered)."""
    if not request.required or answers.settled(request):
        return None
    return next(n for n in request.names if n not in answers.refused)


def refusal_line(requests: list[ParamRequest], answers: ParamAnswers, budget_s: float) -> str | None:
    """The one line naming the needed parameter without a value (the first; how many more), or None."""
    refused = [p for r in requests if (p := _refused(r, answers)) is not None]
    if refused:
        more = f" (and {len(refused) - 1} more)" if len(refused) > 1 else ""
        return f"refusing to engage: {refused[0]}{more}; the commands depend on it"
    unread = [n for r in requests if (n := _unread(r, answers)) is not None]
    if not unread:
        return None
    also = f" (also unread: {', '.join(unread[1:4])}{', ...' if len(unread) > 4 else ''})" if len(unread) > 1 else ""
    tries = answers.tries[unread[0]]
    return (f"refusing to engage: {unread[0]} not readable: no answer to {tries} requests within the {budget_s:g} s "
            f"parameter budget{also}; the commands depend on it: check the link, or raise param_budget_s "
            "(--param-budget)")


def read_command_parameters(link: Any, output: str, attitude_form: str | None) -> CommandParameters:
    """Read what ``output``'s commands depend on (the RC calibration as soon as RCMAP names its channels),
    within the link's parameter budget; never raises for what is missing (see ``refusal``)."""
    start = time.monotonic()
    first = first_round(output, attitude_form)
    answers = read_parameters(link, first, link.param_budget, link.retry.timeout_s,
                              follow=lambda answered: second_round(output, answered.values))
    requests = first + second_round(output, answers.values)
    names = [n for r in requests for n in r.names]
    return CommandParameters(
        dict(answers.values), tuple(names), refusal_line(requests, answers, link.param_budget.total_s),
        tuple(n for n in names if answers.refused.get(n) == "does not exist" and n in OPTIONAL),
        tuple(n for r in requests if not r.required and not answers.settled(r) for n in r.names),
        sum(answers.tries.values()), time.monotonic() - start)


def rc_setup(values: dict[str, float]) -> RcSetup:
    """How the autopilot reads our overrides, from the values read; ValueError naming what is unusable."""
    channels = rc_channels(values)
    if channels is None:
        roll, throttle = values.get("RCMAP_ROLL", 0.0), values.get("RCMAP_THROTTLE", 0.0)
        raise ValueError(f"RCMAP_ROLL {roll:g}, RCMAP_THROTTLE {throttle:g}: the companion needs two distinct "
                         "input channels in 1..8")
    steer, throttle = channels

    def calibration(ch: int) -> RcCalibration:
        return RcCalibration(*(round(values[f"RC{ch}_{s}"]) for s in CALIBRATION[:4]))

    return RcSetup(calibration(steer), calibration(throttle), steer, throttle, round(values["PILOT_STEER_TYPE"]),
                   bool(values[f"RC{steer}_REVERSED"]), bool(values[f"RC{throttle}_REVERSED"]))


def engage_problem(params: CommandParameters, ctx: Context) -> str | None:
    """Why the companion must not engage with these parameters (one line), or None: one unread, a value the
    rules table enforces (``preflight.rules``), an unusable RC setup, no speed to scale GUIDED's thrust, the tau
    form's gains unusable or a D term on (integrators are the output feedback's: ``guided.feedback``)."""
    if params.refusal is not None:
        return params.refusal
    violations = enforced_violations(params.values.get, ctx)
    if violations:
        return f"refusing to engage: {violations[0]}"
    try:
        if ctx.rc_mode:
            rc_setup(params.values)
            return None
        if default_speed(params.values.get) is None:
            return "refusing to engage: WP_SPEED and CRUISE_SPEED are both 0: GUIDED's thrust has no speed to scale"
        if ctx.attitude_form == "tau":
            problem = RoverLoops.from_values(params.values).gain_problem(integrators_allowed=True)
            return f"refusing to engage: attitude_form tau: {problem}" if problem else None
    except ValueError as exc:
        prefix = "attitude_form tau: " if ctx.attitude_form == "tau" and not ctx.rc_mode else ""
        return f"refusing to engage: {prefix}{exc}"
    return None


def values_problem(values: dict[str, float], ctx: Context, attitude_form: str | None) -> str | None:
    """``engage_problem`` for values known already (a log's parameters, in a replay): what ``ctx``'s output needs
    and the values lack is named the way an unread one is."""
    requests = first_round(ctx.output, attitude_form) + second_round(ctx.output, values)
    missing = [r.names[0] for r in requests if r.required and not any(n in values for n in r.names)]
    if missing:
        return f"refusing to engage: {missing[0]} not in the values given; the commands depend on it"
    return engage_problem(CommandParameters(dict(values), (), None, (), (), 0, 0.0), ctx)


def read_or_refuse(link: Any, ctx: Context, log: Any) -> CommandParameters:
    """``read_command_parameters`` for ``ctx``'s output, its summary logged; LinkError with ``engage_problem``'s
    line when the companion must not engage."""
    params = read_command_parameters(link, ctx.output, ctx.attitude_form)
    problem = engage_problem(params, ctx)
    if problem is not None:
        raise LinkError(problem)
    log(f"parameters: {params.summary()}" + (f"; optional, not read: {', '.join(params.unread)}"
                                              if params.unread else ""))
    return params
