"""NmpcConfig: the controller's weights, horizon, discretisation, input bounds and solver choice."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from vessel.config import ConfigError, bounded, validate
from vessel.vessel_spec import VesselSpec

SOLVERS = ("ipopt", "rti", "asrti", "nrti")
INTEGRATORS = ("euler", "rk4")
INPUTS = ("tau", "propellers")
TAU_BOX = ("tau_x_max_n", "tau_x_min_n", "tau_n_max_nm")  # the τ inputs' box: not for propeller inputs
STRUCTURAL = "structural"  # field metadata key: the field changes the built problem


def choice(default: str, choices: tuple[str, ...], doc: str = "") -> str:
    """A text field restricted to ``choices`` (checked by vessel.config on load)."""
    return dataclasses.field(default=default, metadata={"choices": choices, "doc": doc})


def structural(spec: Any) -> Any:
    """Mark a field as structural: it changes the built CasADi problem, so it is part of the build key.

    The other fields are run-time parameters of the NLP (weights) or options of a solver instance,
    which every controller builds for itself.
    """
    return dataclasses.field(default=spec.default, metadata={**spec.metadata, STRUCTURAL: True})


@dataclass(frozen=True)
class NmpcConfig:
    """Everything that defines the NMPC problem and its solver (SI units, radians)."""

    q: float = bounded(5.0, 0.0, 1e6, "", "heading-error weight Q (per rad²)")
    r: float = bounded(1550.0, 0.0, 1e7, "", "roll weight R (per rad²)")
    s: float = bounded(2.0, 0.0, 1e6, "", "distance weight S (per m)")
    w_dtau_x: float = bounded(1.0, 0.0, 1e6, "", "input-change weight W11 (per N²)")
    w_dtau_n: float = bounded(1.0, 0.0, 1e6, "", "input-change weight W22 (per (N·m)²)")
    horizon: int = structural(bounded(40, 1, 400, "steps", "prediction horizon P"))
    period_s: float = structural(bounded(0.1, 0.01, 2.0, "s", "sampling period T"))
    substeps: int = structural(bounded(2, 1, 50, "", "integrator sub-steps per period"))
    integrator: str = structural(choice("euler", INTEGRATORS, "explicit Euler or RK4 per sub-step"))
    inputs: str = structural(choice("tau", INPUTS, "the model's input: tau (τ_X, τ_N) in the box below, the paper's "
                                    "setting; or propellers (left, right thrust, N) each within what its "
                                    "propeller gives forward and in reverse (the allocation's envelope; the "
                                    "tau_* bounds then do not apply)"))
    tau_x_max_n: float = bounded(150.0, 1.0, 1000.0, "N", "largest forward surge force")
    tau_x_min_n: float = bounded(-150.0, -1000.0, 0.0, "N", "largest reverse surge force (negative)")
    tau_n_max_nm: float = bounded(73.6, 0.1, 1000.0, "N·m", "largest |yaw moment|")
    min_speed_mps: float = structural(bounded(0.5, 0.0, 5.0, "m/s", "soft minimum surge speed"))
    min_speed_fade_m: float = structural(bounded(10.0, 0.0, 1000.0, "m", "the minimum speed fades linearly to 0 "
                                                 "within this distance of the waypoint, so the boat may slow to "
                                                 "turn in rather than circle it (0: never fades, the paper's cost)"))
    roll_fade_m: float = structural(bounded(8.0, 0.0, 1000.0, "m", "the roll terms fade to 0 near the waypoint, half "
                                           "their weight at this distance (0: never, the paper's cost; see "
                                           "problem.roll_fade)"))
    wave_components: int = structural(bounded(0, 0, 256, "", "K long-crested components of a phase-resolved sea the "
                                              "model adds to its regular wave (the ``bank`` parameter block, "
                                              "see nmpc.wave_bank); 0: none, the problem as without the option"))
    min_speed_weight: float = structural(bounded(1e4, 0.0, 1e9, "", "penalty weight on (min speed − u)² below it"))
    heading_limit_deg: float = structural(bounded(80.0, 0.0, 179.0, "deg", "soft limit on the heading error: beyond "
                                                  "it the cost rises steeply (weight heading_limit_weight), so the "
                                                  "boat may tack but turns back before sailing away (0: no "
                                                  "limit, the paper's cost; see problem.heading_excess)"))
    heading_limit_weight: float = structural(bounded(1e4, 0.0, 1e9, "", "penalty weight on the heading error's "
                                                     "excess over heading_limit_deg, per rad²"))
    solver: str = choice("ipopt", SOLVERS, "ipopt (reference), rti (Gauss–Newton SQP with HPIPM) or asrti "
                         "(rti corrected from a converged SQP solve for the predicted state, run in the background) "
                         "or nrti (asrti with a native preparation/feedback split: condensed QP in C)")
    max_iter: int = bounded(50, 0, 10000, "", "IPOPT iteration limit")
    rti_iterations: int = bounded(2, 1, 20, "", "SQP iterations per step, at least (rti)")
    rti_max_iterations: int = bounded(2, 1, 50, "", "SQP iterations per step, at most (rti)")
    rti_step_tol: float = bounded(1.0, 0.0, 1e6, "N, N·m", "rti: iterate past the minimum while an input "
                                  "step exceeds this")
    rti_qp_iter_max: int = bounded(4, 0, 1000, "", "HPIPM iteration cap per QP (rti; 0 = HPIPM's default)")
    as_iterations: int = bounded(1, 1, 20, "", "asrti: SQP iterations per step from the background plan")
    as_max_iterations: int = bounded(30, 1, 200, "", "asrti: SQP iteration limit of the background solve")
    as_step_tol: float = bounded(0.3, 0.0, 1e6, "N, N·m", "asrti: the background solve stops when every input "
                                 "step is below this")
    # 60 s: in-process experiments and sweeps wait for the background solve whatever the machine's load, so
    # a run is the same on every computer and executor; the companion caps it at a quarter period (wall time).
    as_wait_s: float = bounded(60.0, 0.0, 60.0, "s", "asrti: longest wait at a step for the background solve "
                               "started at the previous one (beyond it: plain rti from the shifted plan)")
    as_worker: str = choice("thread", ("thread", "process", "inline"), "asrti: run the background solve in a thread "
                            "(CasADi releases the GIL while it computes), in a worker process (no GIL sharing), or "
                            "inline, when the next step takes it (no thread; in-process runs wait for it anyway, and "
                            "set it themselves; paced flight turns it into a thread)")
    rti_codegen: str = choice("auto", ("auto", "off"),
                              "rti, asrti: compile the linearisation and the HPIPM conic to C (cached) or not")
    heave_feedback: str = choice("auto", ("auto", "measured", "none"), "the heave the model is given: measured, "
                                 "none (down = 0, no vertical velocity: the hull on its calm waterline, for a hull "
                                 "that rides the sea) or auto (none where the hull heaves with the sea)")
    safe_surge_n: float = bounded(30.0, 0.0, 1000.0, "N", "fallback surge force when there is no plan")
    model: VesselSpec = dataclasses.field(default_factory=VesselSpec, metadata={"doc": "the hull the controller "
                                          "predicts with, whatever the boat is: a named set (published, corrected), "
                                          "a mapping {base, <OtterParameters field>: value} or a vessel YAML file "
                                          "(as `mavbridge identify` writes)"})

    def __post_init__(self) -> None:
        if not isinstance(self.model, VesselSpec):  # NmpcConfig(model="corrected") reads as in a file
            object.__setattr__(self, "model", VesselSpec.from_config(self.model, "model"))
        validate(self)
        for f in dataclasses.fields(self):
            choices = f.metadata.get("choices")
            if choices and getattr(self, f.name) not in choices:
                raise ConfigError(f"{f.name}: {getattr(self, f.name)!r} is not one of {', '.join(choices)}")
        if self.rti_max_iterations < self.rti_iterations:
            raise ConfigError(f"rti_max_iterations: {self.rti_max_iterations} is below rti_iterations "
                              f"{self.rti_iterations}; allowed [rti_iterations, 50]")
        self._refuse_box_with_propellers()
        if self.safe_surge_n > self.tau_x_max_n:
            bound = "tau_x_max_n" if self.inputs == "tau" else "the default τ box"
            raise ConfigError(f"safe_surge_n: {self.safe_surge_n:g} N exceeds {bound} "
                              f"{self.tau_x_max_n:g} N; allowed [0, {self.tau_x_max_n:g}] N")

    def _refuse_box_with_propellers(self) -> None:
        """A τ box set together with propeller-thrust inputs would be silently ignored: refuse it instead.
        (A box equal to the defaults cannot be told apart from none here: it is not used either.)"""
        if self.inputs != "propellers":
            return
        for name in TAU_BOX:
            field = next(f for f in dataclasses.fields(self) if f.name == name)
            if getattr(self, name) != field.default:
                raise ConfigError(f"{name}: does not apply with inputs: propellers (each propeller's own thrust "
                                  f"limits bound the inputs); remove it, or use inputs: tau")

    @property
    def weights(self) -> tuple[float, float, float, float, float]:
        """(Q, R, S, W11, W22), the runtime parameters of the NLP."""
        return (self.q, self.r, self.s, self.w_dtau_x, self.w_dtau_n)

    def structural(self) -> tuple[tuple[str, Any], ...]:
        """(name, value) of the fields marked ``structural``: the key of the built CasADi problem."""
        return tuple((f.name, getattr(self, f.name)) for f in dataclasses.fields(self) if f.metadata.get(STRUCTURAL))

    def replace(self, **changes: object) -> NmpcConfig:
        """A copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)
