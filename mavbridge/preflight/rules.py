"""The ArduPilot Rover parameters the companion relies on, as one table of rules.

Each ``Rule`` names a parameter (and the names other firmware versions give it), what is expected,
and an ordered list of ``Condition``s; the first condition that does not hold decides the finding
(its severity, its fix), and a parameter whose conditions all hold passes. Conditions marked
``enforced`` are the ones `mavbridge run` itself refuses to engage against: for RC overrides an autopilot
that would silently ignore every override (``RC``), for every path whose commands pass through the skid
mixer's inverse a mixer other than the one it inverts (``SKID``: RC overrides and GUIDED's tau form), and
a vehicle that is no boat (``ALWAYS``). The preflight check and the companion read them from this one table
(``evaluate`` and ``enforced_violations``); which parameters the companion must read at all, and which it may
go without, is ``mavbridge.companion.parameters``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

from mavbridge.preflight.report import FAIL, PASS, WARN, Report

Reader = Callable[[str], float | None]
THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74
FS_ACTIONS = {0: "none", 1: "RTL", 2: "Hold", 3: "SmartRTL or RTL or Hold", 4: "SmartRTL or Hold", 5: "Terminate",
              6: "Loiter or Hold"}
RC_OPTIONS_IGNORE_OVERRIDES = 2  # RC_OPTIONS bit 1: ignore MAVLink RC overrides


@dataclass(frozen=True)
class Context:
    """What the rules are judged against: the companion's id and output, the control period, the scenario."""

    system_id: int
    output: str  # rc_override or attitude_target
    period_s: float
    acceptance_m: float
    attitude_form: str = "rate"  # attitude_target's form (heading, rate or tau); unused for rc_override

    @property
    def rc_mode(self) -> bool:
        """True when the companion flies RC overrides (MANUAL)."""
        return self.output == "rc_override"

    @property
    def skid_inverse(self) -> bool:
        """True when the commands are computed through the inverse of Rover's skid mixer (RC, or GUIDED's tau)."""
        return self.rc_mode or self.attitude_form == "tau"


NEVER, RC, SKID, ALWAYS = "", "rc", "skid", "always"  # when `mavbridge run` enforces a condition (see the docstring)
_ENFORCED_WHEN = {NEVER: lambda c: False, RC: lambda c: c.rc_mode, SKID: lambda c: c.skid_inverse,
                  ALWAYS: lambda c: True}


Text = str | Callable[[float | None, Context], str]


@dataclass(frozen=True)
class Condition:
    """One requirement on a parameter's value (None = not readable), with the fix when it is not met.

    Texts are templates: ``{value}`` (as the user would type it), ``{name}`` (the parameter read) and
    the ``Context`` fields (``{system_id}``, ``{period_s:g}``, ``{acceptance_m:g}``); or callables.
    """

    holds: Callable[[float | None, Context], bool]
    fix: Text
    severity: str = FAIL
    guided: str | None = None  # the severity when the output is attitude_target (default: ``severity``)
    expected: str | None = None  # this finding's expected text, if not the rule's
    note: str = ""  # appended to the actual value, e.g. " (never expires)"
    enforced: str = NEVER  # when `mavbridge run` refuses to engage if this fails on a readable value

    def status(self, ctx: Context) -> str:
        """The severity for this output."""
        return self.severity if ctx.rc_mode or self.guided is None else self.guided

    def enforced_for(self, ctx: Context) -> bool:
        """True when `mavbridge run` with this context refuses to engage on a readable value that fails it."""
        return bool(_ENFORCED_WHEN[self.enforced](ctx))


@dataclass(frozen=True)
class Rule:
    """A parameter, what is expected of it, and the conditions in the order they are judged."""

    parameter: str
    expected: str
    conditions: tuple[Condition, ...]
    aliases: tuple[str, ...] = ()  # the same parameter under another firmware's name (read when unreadable)
    unit: str = ""  # appended to the actual value
    skip_unreadable: bool = False  # no finding at all when the autopilot does not have it
    describe: Callable[[float], str] | None = None  # the actual value as shown when it passes


def fmt_value(value: float | None) -> str:
    """A parameter value as the user would type it."""
    return "not readable" if value is None else f"{value:g}"


def _text(text: Text, value: float | None, name: str, ctx: Context) -> str:
    if callable(text):
        return text(value, ctx)
    return text.format(value=fmt_value(value), name=name, **dataclasses.asdict(ctx))


def _is(expected: int) -> Callable[[float | None, Context], bool]:
    return lambda v, _c: v is not None and int(v) == expected


def _readable(v: float | None, _c: Context) -> bool:
    return v is not None


def _servo(servo: int, function: int, side: str) -> Rule:
    thruster = "left" if function == THROTTLE_LEFT else "right"
    return Rule(f"SERVO{servo}_FUNCTION", f"{function} ({side})", (
        Condition(_is(function), f"set SERVO{servo}_FUNCTION {function}: the companion's mixer assumes output "
                                 f"{servo} drives the {thruster} thruster", enforced=SKID),))


_GCS = Condition(lambda v, c: v is not None and int(v) == c.system_id,
                 "set {name} {system_id}, or system_id: {value} in the companion config; the autopilot obeys RC "
                 "overrides only from that system", FAIL, WARN, enforced=RC)
_LAPSE = "set RC_OVERRIDE_TIME 0.5: "
RULES: tuple[Rule, ...] = (
    Rule("SYSID_MYGCS", "{system_id} (companion system_id)", (_GCS,), aliases=("MAV_GCS_SYSID",)),  # 4.7 renamed it
    _servo(1, THROTTLE_LEFT, "ThrottleLeft"),
    _servo(3, THROTTLE_RIGHT, "ThrottleRight"),
    Rule("FRAME_CLASS", "2 (boat)", (Condition(_is(2), "set FRAME_CLASS 2 and reboot the autopilot",
                                               enforced=ALWAYS),)),
    Rule("RC_OVERRIDE_TIME", "> {period_s:g} s (control period), <= 2 s", (
        Condition(_readable, "check the link", FAIL, WARN),
        Condition(lambda v, _c: v != 0, _LAPSE + "at 0 the autopilot ignores RC overrides", FAIL, WARN,
                  enforced=RC),
        Condition(lambda v, _c: v is not None and v >= 0, _LAPSE + "with -1 a stalled companion's last command "
                  "never times out", FAIL, WARN, note=" (never expires)"),
        Condition(lambda v, c: v is not None and v > c.period_s, _LAPSE + "at or below the {period_s:g} s control "
                  "period the overrides lapse between two commands", FAIL, WARN),
        Condition(lambda v, c: v is not None and 3 * c.period_s <= v <= 2.0, _LAPSE + "shorter lapses on one late "
                  "command, longer keeps a stalled companion's last command that long", WARN,
                  expected="{three_periods_s:g}..2 s"),
    ), unit=" s"),
    Rule("RC_OPTIONS", "bit 1 (2, ignore MAVLink overrides) clear", (
        Condition(lambda v, _c: v is None or not int(v) & RC_OPTIONS_IGNORE_OVERRIDES,
                  lambda v, _c: f"set RC_OPTIONS {int(v or 0) & ~RC_OPTIONS_IGNORE_OVERRIDES}: the autopilot ignores "
                                "MAVLink RC overrides", FAIL, WARN, enforced=RC),
    ), skip_unreadable=True),
    Rule("WP_SPEED", "> 0 m/s", (Condition(lambda v, _c: v is not None and v > 0, "set WP_SPEED 2: Rover refuses "
                                           "to arm at 0, and GUIDED thrust is a fraction of it"),)),
    Rule("WP_RADIUS", "{acceptance_m:g} m (scenario acceptance)", (
        Condition(lambda v, c: v is not None and abs(v - c.acceptance_m) <= 0.05,
                  "set WP_RADIUS {acceptance_m:g} so that AUTO and the companion agree on arrival", WARN),
    ), unit=" m"),
    Rule("MOT_SLEWRATE", "0 (off) or >= 1000 %/s", (
        Condition(lambda v, c: not c.rc_mode or v is None or not 0 < v < 1000,
                  "set MOT_SLEWRATE 0: the autopilot's throttle slew lags the NMPC's commands and skews the "
                  "left/right split the companion computed", WARN),
    ), unit=" %/s", skip_unreadable=True),
    Rule("FS_ACTION", "1..6 (2 = Hold)", (
        Condition(lambda v, _c: v is not None and int(v) != 0,
                  "set FS_ACTION 2: with 0 a lost transmitter or GCS link does nothing"),
    ), describe=lambda v: f"{int(v)} ({FS_ACTIONS.get(int(v), '?')})"),
    Rule("FS_TIMEOUT", "0.5..5 s", (
        Condition(lambda v, _c: v is not None and 0.5 <= v <= 5.0, "set FS_TIMEOUT 1.5 (Rover's default)", WARN),
    ), unit=" s"),
    Rule("FS_THR_ENABLE", ">= 1 (RC failsafe on)", (
        Condition(lambda v, _c: v is not None and int(v) != 0, "set FS_THR_ENABLE 1: otherwise losing the safety "
                  "pilot's transmitter goes unnoticed", WARN),)),
    Rule("FS_GCS_ENABLE", "0 (see deploy/otter-rover.parm)", (
        Condition(lambda v, _c: v is None or int(v) < 1,
                  "the companion (the GCS that SYSID_MYGCS names) ends its process after every run; FS_ACTION then "
                  "follows within FS_GCS_TIMEOUT, even under a pilot in MANUAL. Set 0 unless that is wanted", WARN),
    )),
    Rule("ARMING_CHECK", "!= 0", (
        Condition(lambda v, _c: v is None or int(v) != 0, "set ARMING_CHECK 1: pre-arm checks catch bad GPS/compass",
                  WARN),
    ), skip_unreadable=True),
)


def _read_rule(rule: Rule, read: Reader) -> tuple[str, float | None]:
    """(name read, value): the parameter, else the first alias that answers (else the last name tried)."""
    name, value = rule.parameter, read(rule.parameter)
    for alias in rule.aliases:
        if value is not None:
            break
        name, value = alias, read(alias)
    return name, value


def _actual(rule: Rule, value: float | None, note: str = "") -> str:
    return "not readable" if value is None else f"{value:g}{rule.unit}{note}"


def judge(rule: Rule, name: str, value: float | None, ctx: Context, report: Report) -> None:
    """Add the rule's finding for ``value`` of parameter ``name`` to the report."""
    fields = {**dataclasses.asdict(ctx), "three_periods_s": 3 * ctx.period_s}
    expected = rule.expected.format(**fields)
    for cond in rule.conditions:
        if not cond.holds(value, ctx):
            shown = cond.expected.format(**fields) if cond.expected else expected
            fix = _text(cond.fix, value, name, ctx)
            report.add(cond.status(ctx), name, shown, _actual(rule, value, cond.note), fix)
            return
    shown = rule.describe(value) if rule.describe and value is not None else _actual(rule, value)
    report.add(PASS, name, expected, shown)


def evaluate(read: Reader, ctx: Context, report: Report, rules: tuple[Rule, ...] = RULES) -> None:
    """Judge every rule against the values ``read(name)`` returns (None = not readable)."""
    for rule in rules:
        name, value = _read_rule(rule, read)
        if value is None and rule.skip_unreadable:
            continue
        judge(rule, name, value, ctx, report)


def enforced_violations(read: Reader, ctx: Context, rules: tuple[Rule, ...] = RULES) -> list[str]:
    """The conditions enforced for ``ctx`` that readable values break: why `mavbridge run` refuses to engage."""
    problems = []
    for rule in rules:
        enforced = [c for c in rule.conditions if c.enforced_for(ctx)]
        if not enforced:
            continue
        name, value = _read_rule(rule, read)
        if value is None:
            continue  # not readable: the check reports it; what the companion must read is refused before
        for cond in enforced:
            if not cond.holds(value, ctx):
                expected = rule.expected.format(**dataclasses.asdict(ctx))
                problems.append(f"{name} is {_actual(rule, value)}, expected {expected}: "
                                f"{_text(cond.fix, value, name, ctx)}")
    return problems


def rc_findings(report: Report, channel: int, values: dict[str, float | None]) -> None:
    """RCn_MIN/TRIM/MAX: readable, within 800..2200 µs, MIN < TRIM < MAX with room either side of TRIM."""
    name = f"RC{channel}_MIN/TRIM/MAX"
    lo, trim, hi = values["MIN"], values["TRIM"], values["MAX"]
    expected = "800 <= MIN < TRIM < MAX <= 2200"
    if lo is None or trim is None or hi is None:
        report.add(FAIL, name, expected, "not readable",
                   f"the companion turns forces into PWM with RC{channel}_MIN/TRIM/MAX; check the link")
        return
    actual = f"{lo:g}/{trim:g}/{hi:g}"
    fix = f"calibrate the transmitter (radio calibration) or set RC{channel}_MIN 1100, _TRIM 1500, _MAX 1900"
    if not (800 <= lo < trim < hi <= 2200):
        report.add(FAIL, name, expected, actual, fix)
    elif trim - lo < 100 or hi - trim < 100:
        which = "reverse" if channel == 3 else "one side of steering"
        report.add(WARN, name, "TRIM >= 100 µs from MIN and MAX", actual,
                   f"TRIM close to an end leaves little {which}; " + fix)
    else:
        report.add(PASS, name, expected, actual)


def parameter_findings(report: Report, read: Reader, system_id: int, output: str, period_s: float,
                       acceptance_m: float, channels: tuple[int, int] = (1, 3)) -> None:
    """Every parameter rule, then the RC calibration of the steering and throttle inputs (``channels``: the
    ones RCMAP_ROLL/RCMAP_THROTTLE name; Rover's 1 and 3 by default)."""
    evaluate(read, Context(system_id, output, period_s, acceptance_m), report)
    for channel in dict.fromkeys(channels):
        rc_findings(report, channel, {s: read(f"RC{channel}_{s}") for s in ("MIN", "TRIM", "MAX")})


def tau_form_findings(report: Report, read: Reader, read_optional: Reader) -> None:
    """What GUIDED's tau form needs (``mavbridge.companion.guided.inverse``), judged as `mavbridge run` judges
    it: Rover's loop gains readable, its D gains 0 (FAIL: the companion refuses the form; integrators on are said:
    the companion then closes the inversion on SERVO_OUTPUT_RAW), WP_SPEED at least the speed target full
    throttle needs and ATC_BRAKE 1 (WARN: the plan's full thrust, or its braking, would be cut)."""
    from mavbridge.companion.guided.inverse import (
        BRAKE,
        LOOP_PARAMETERS,
        OPTIONAL_LOOP_PARAMETERS,
        RoverLoops,
        default_speed,
    )

    values = {name: read(name) for name in LOOP_PARAMETERS}
    values.update({name: read_optional(name) for name in (*OPTIONAL_LOOP_PARAMETERS, BRAKE)})
    parm = "load deploy/otter-guided-tau.parm"
    fix = parm + ", or use attitude_form rate"
    try:
        loops = RoverLoops.from_values(values)
    except ValueError as exc:
        report.add(FAIL, "tau form: loop gains", "readable, >= 0", str(exc), "check the link; " + fix)
        return
    on, gains = loops.gain_on(integrators_allowed=True), "ATC_STR_RAT_D, ATC_SPEED_D 0"
    absent = [name for name in loops.absent if name != BRAKE]
    if on:
        report.add(FAIL, "tau form: D gains", gains, f"{on[0]} is {on[1]:g}", fix)
    else:
        integrators = ("; the integrators are on: the companion closes the inversion on SERVO_OUTPUT_RAW"
                       if loops.integrators_on else "")
        report.add(PASS, "tau form: D gains", gains, "0" + integrators
                   + (f" ({', '.join(absent)} not on this autopilot: 0)" if absent else ""))
    wp_speed = default_speed(read)
    needed = loops.full_throttle_target_mps()
    status = FAIL if wp_speed is None else WARN if loops.wp_speed_problem(wp_speed) else PASS
    report.add(status, "tau form: WP_SPEED", f">= {needed:.2f} m/s (full throttle's speed target)",
               "not readable or 0" if wp_speed is None else f"{wp_speed:g} m/s",
               f"set WP_SPEED >= {needed:.2f} ({parm}): it caps Rover's speed target, cutting full thrust")
    brake = values[BRAKE]
    report.add(PASS if brake else WARN, "tau form: ATC_BRAKE", "1 (the speed loop may reverse)", fmt_value(brake),
               f"set ATC_BRAKE 1 ({parm}): at 0 Rover zeroes the plan's reverse thrust while the target is ahead")
