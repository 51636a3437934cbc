"""The house's rooms (issue 31): no folder holds more than 20 modules, every package says what lives there and
what may import it, and the packages import each other only as the table below (and their docstrings) say."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("vessel", "sim_vehicle", "mavbridge", "mission")
MAX_MODULES = 20

ROOMS = {  # a room, and the rooms (other than itself and its own subpackages) it may import
    "vessel": {"vessel.sea"},
    "vessel.sea": {"vessel"},
    "sim_vehicle": {"vessel", "vessel.sea", "sim_vehicle.rover", "sim_vehicle.mavlink", "sim_vehicle.json_backend"},
    "sim_vehicle.rover": {"vessel", "sim_vehicle", "sim_vehicle.mavlink"},
    "sim_vehicle.mavlink": {"vessel", "sim_vehicle", "sim_vehicle.rover"},
    "sim_vehicle.json_backend": {"vessel", "vessel.sea", "sim_vehicle", "sim_vehicle.rover"},
    "mavbridge": {"vessel"},
    "mavbridge.link": {"vessel"},
    "mavbridge.waves": {"vessel", "vessel.sea"},
    "mavbridge.waves.phase": {"vessel", "vessel.sea", "mavbridge.waves"},
    "mavbridge.nmpc": {"vessel", "vessel.sea", "mavbridge.nmpc.solvers"},
    "mavbridge.nmpc.solvers": {"vessel", "mavbridge.nmpc"},
    "mavbridge.companion.guided": {"vessel", "mavbridge.link", "mavbridge.companion"},
    "mavbridge.companion.identify_run": {"vessel", "mavbridge.link", "mavbridge.companion"},
    "mavbridge.companion": {"vessel", "vessel.sea", "mavbridge.link", "mavbridge.nmpc", "mavbridge.waves",
                            "mavbridge.lab", "mavbridge.preflight"},
    "mavbridge.lab": {"vessel", "vessel.sea", "mavbridge.nmpc", "mavbridge.waves", "mavbridge.waves.phase",
                      "mavbridge.companion"},
    "mavbridge.preflight": {"vessel", "mavbridge.link", "mavbridge.companion", "mavbridge.nmpc", "mavbridge.lab",
                            "mavbridge.cli", "mavbridge.companion.guided"},
    "mavbridge.sweep": {"vessel", "vessel.sea", "mavbridge.lab", "mavbridge.nmpc", "mavbridge.cli"},
    "mavbridge.field": {"vessel", "mavbridge.link", "mavbridge.companion", "mavbridge.companion.guided",
                        "mavbridge.waves", "mavbridge.nmpc", "mavbridge.lab", "mavbridge.preflight", "mavbridge.cli"},
    "mavbridge.field.replay": {"vessel", "mavbridge.link", "mavbridge.companion", "mavbridge.waves", "mavbridge.lab",
                               "mavbridge.preflight", "mavbridge.nmpc",
                               "mavbridge.cli", "mavbridge.field"},
    "mavbridge.identify": {"vessel", "mavbridge.field"},
    "mavbridge.cli": {"vessel", "mavbridge.link", "mavbridge.companion", "mavbridge.lab", "mavbridge.nmpc",
                      "mavbridge.preflight", "mavbridge.sweep", "mavbridge.waves", "mavbridge.field",
                      "mavbridge.identify", "mavbridge.companion.identify_run"},
    "mission": {"vessel"},
}


def _packages() -> list[Path]:
    return sorted(p.parent for pkg in PACKAGES for p in (ROOT / pkg).rglob("__init__.py"))


def _room(module: str) -> str:
    """The deepest room in ROOMS that holds ``module`` (a dotted name)."""
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in ROOMS:
            return ".".join(parts[:n])
    raise AssertionError(f"{module} is in no room of ROOMS: add its package there")


def test_no_folder_holds_more_than_20_modules() -> None:
    crowded = {str(d.relative_to(ROOT)): n for d in _packages() if (n := len(list(d.glob("*.py")))) > MAX_MODULES}
    assert not crowded, f"folders over {MAX_MODULES} modules: {crowded}"


def test_every_package_is_a_room_that_says_who_may_import_it() -> None:
    for package in _packages():
        name = ".".join(package.relative_to(ROOT).parts)
        assert name in ROOMS, f"{name} has no line in ROOMS"
        doc = ast.get_docstring(ast.parse((package / "__init__.py").read_text())) or ""
        assert len(doc) > 80 and "import" in doc.lower(), f"{name}/__init__.py: say what lives there and who imports"


def test_rooms_import_only_what_the_table_allows() -> None:
    wrong = {}
    for path in sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        room = _room(module)
        for node in ast.walk(ast.parse(path.read_text())):
            names = [node.module] if isinstance(node, ast.ImportFrom) and node.module else (
                [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            for target in (n for n in names if n.split(".")[0] in PACKAGES):
                other = _room(target)
                if other != room and not other.startswith(room + ".") and other not in ROOMS[room]:
                    wrong.setdefault(module, set()).add(target)
    assert not wrong, f"imports the room table does not allow: {wrong}"


def test_every_room_that_imports_the_command_line_imports_first() -> None:
    """A room's command line imported before ``mavbridge.cli`` (a bench, a test collected alone) does not meet
    itself half-built: ``mavbridge.cli.main`` imports the rooms' parsers only when it builds its own."""
    rooms = ("mavbridge.preflight.cli", "mavbridge.field.cli", "mavbridge.sweep.cli", "mavbridge.field.replay",
             "mavbridge.identify.cli")
    program = "; ".join(f"import importlib, sys; importlib.import_module({room!r}); "
                        f"[sys.modules.pop(m) for m in list(sys.modules) if m.startswith('mavbridge')]"
                        for room in rooms)
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
