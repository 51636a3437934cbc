"""A vessel as configuration spells it: a named set, a mapping of changes on a base set, or a vessel file.

The same three forms describe the simulator's plant (a world's ``vessel:``), the controller's model
(``controller.model:``) and the companion's model (its config's ``model:``)::

    vessel: published                                   # a named set (PARAMETER_SETS)
    vessel: {base: published, payload_mass: 60.0}       # a base set and any OtterParameters fields
    vessel: boats/otter-7.yaml                          # a file holding such a mapping (``mavbridge identify``
                                                        # writes one); relative to the file that names it

Every field is validated as OtterParameters declares it (unit, range); an error is one line naming the
file and the key. A spec is frozen and hashable, compares by what it builds (base and changes; not by the
file it came from), and writes back as the name alone or as the mapping (``to_config``), so a resolved
scenario saved with ``yaml.safe_dump`` loads to the same boat.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vessel.config import ConfigError, from_mapping, read_yaml, to_mapping
from vessel.params import PARAMETER_SETS, OtterParameters, otter_parameters

_CONFIG_DIR: contextvars.ContextVar[Path | None] = contextvars.ContextVar("vessel_config_dir", default=None)


@contextlib.contextmanager
def relative_to(path: str | Path | None) -> Iterator[None]:
    """Vessel files named while this is active are found relative to the folder of the file ``path`` (outside it,
    and for command-line flags, relative to the working folder)."""
    token = _CONFIG_DIR.set(Path(path).parent if path else None)
    try:
        yield
    finally:
        _CONFIG_DIR.reset(token)


def _fields() -> dict[str, dataclasses.Field[Any]]:
    return {f.name: f for f in dataclasses.fields(OtterParameters)}


@dataclass(frozen=True)
class VesselSpec:
    """An Otter parameter set: ``base`` (a named set) with ``changes`` (OtterParameters field -> value)."""

    base: str = PARAMETER_SETS[0]
    changes: tuple[tuple[str, Any], ...] = ()
    source: str = dataclasses.field(default="", compare=False)  # the vessel file it was read from, if any

    def __post_init__(self) -> None:
        if self.base not in PARAMETER_SETS:
            raise ConfigError(f"base: {self.base!r} is not one of {', '.join(PARAMETER_SETS)}")

    def params(self) -> OtterParameters:
        """The OtterParameters this spec describes (built once, then kept on it)."""
        built = self.__dict__.get("_params")
        if built is None:
            built = otter_parameters(self.base).replace(**dict(self.changes))
            object.__setattr__(self, "_params", built)
        return built

    @property
    def named(self) -> bool:
        """True for a named set with no changes."""
        return not self.changes

    def describe(self) -> str:
        """One line: 'published', or 'published with payload_mass 60, zeta_roll 0.08' (and the file)."""
        text = self.base if self.named else f"{self.base} with " + ", ".join(
            f"{name} {_short(value)}" for name, value in self.changes)
        return f"{text} (from {self.source})" if self.source else text

    def __str__(self) -> str:
        return self.describe()

    def to_config(self) -> str | dict[str, Any]:
        """Plain data the loaders read back: the name alone, or ``{base, field: value, ...}``."""
        if self.named:
            return self.base
        return {"base": self.base, **{name: to_mapping(value) for name, value in self.changes}}

    @classmethod
    def from_config(cls, value: Any, where: str) -> VesselSpec:
        """A spec from a name, a mapping or a vessel file's path (one-line ConfigErrors naming ``where``)."""
        if isinstance(value, VesselSpec):
            return value
        if isinstance(value, str):
            return cls(value) if value in PARAMETER_SETS else _from_file(value, where)
        if isinstance(value, Mapping):
            return _from_mapping(value, where)
        raise ConfigError(f"{where}: expected one of {', '.join(PARAMETER_SETS)}, a mapping {{base: ..., "
                          f"<OtterParameters field>: value}} or a vessel YAML file, got {value!r}")


def _short(value: Any) -> str:
    if isinstance(value, tuple):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    return f"{value:g}" if isinstance(value, float) else str(value)


def _from_mapping(data: Mapping[str, Any], where: str, source: str = "") -> VesselSpec:
    """``{base: name, field: value, ...}``: every field checked against OtterParameters' range."""
    fields = dict(data)
    base = fields.pop("base", PARAMETER_SETS[0])
    if not isinstance(base, str) or base not in PARAMETER_SETS:
        raise ConfigError(f"{where}.base: {base!r} is not one of {', '.join(PARAMETER_SETS)}")
    known = _fields()
    unknown = sorted(set(map(str, fields)) - set(known))
    if unknown:
        raise ConfigError(f"{where}: unknown key '{unknown[0]}' (allowed: base and the OtterParameters fields, "
                          f"e.g. payload_mass, zeta_roll, gyration_roll, propeller_scale)")
    base_params = otter_parameters(base)
    checked = from_mapping(OtterParameters, {**to_mapping(base_params), **fields}, where)
    changes = tuple((name, getattr(checked, name)) for name in known  # (a field equal to the base's changes nothing)
                    if name in fields and getattr(checked, name) != getattr(base_params, name))
    spec = VesselSpec(base, changes, source)
    spec.params()  # cross-field checks are OtterParameters' own
    return spec


def _from_file(name: str, where: str) -> VesselSpec:
    """A vessel YAML file's mapping (relative paths: to the folder of the file being read, if any)."""
    path = Path(name)
    folder = _CONFIG_DIR.get()
    if not path.is_absolute() and folder is not None:  # beside the file that names it, never the working folder's
        path = folder / path
    if not path.is_file():
        raise ConfigError(f"{where}: {name!r} is neither a named set ({', '.join(PARAMETER_SETS)}) nor a "
                          f"readable vessel file")
    data = read_yaml(path)
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a vessel mapping {{base: ..., <OtterParameters field>: value}}")
    return _from_mapping(data, str(path), str(path))


def load_vessel(value: Any, where: str = "vessel") -> VesselSpec:
    """A vessel from any of the three forms (a name, a mapping, a file path)."""
    return VesselSpec.from_config(value, where)
