"""The house rules that keep the code easy to change: small modules, simple functions, no import cycles."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("vessel", "sim_vehicle", "mavbridge", "mission")
MAX_MODULE_LINES = 400
MAX_CLASS_LINES = 215  # issue 10: "no class over ~200 lines" (a docstring and a property of slack)


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_no_module_over_400_lines() -> None:
    """Every module of the four packages has at most 400 lines."""
    big = {str(p.relative_to(ROOT)): n for p in _modules() if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not big, f"modules over {MAX_MODULE_LINES} lines: {big}"


def test_no_class_over_about_200_lines() -> None:
    """No class of the four packages spans more than MAX_CLASS_LINES lines (split by responsibility)."""
    big = {}
    for path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and (n := node.end_lineno - node.lineno + 1) > MAX_CLASS_LINES:
                big[f"{path.relative_to(ROOT)}:{node.name}"] = n
    assert not big, f"classes over {MAX_CLASS_LINES} lines: {big}"


def test_no_function_over_complexity_12() -> None:
    """ruff's mccabe rule C901 with max 12 passes on the four packages."""
    ruff = Path(sys.executable).with_name("ruff")
    done = subprocess.run([str(ruff), "check", "--select", "C901", "--config", "lint.mccabe.max-complexity=12",
                           "--output-format", "concise", *PACKAGES], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:]


def _imports(path: Path) -> set[str]:
    """Top-level project packages a module imports (absolute, or relative resolved to its package)."""
    tree = ast.parse(path.read_text())
    own = path.relative_to(ROOT).parts[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            found.add(own if node.level else (node.module or "").split(".")[0])
    return found & set(PACKAGES)


def test_layering_holds() -> None:
    """vessel imports nothing of ours; sim_vehicle and mavbridge never import each other; mission neither."""
    allowed = {"vessel": {"vessel"}, "sim_vehicle": {"sim_vehicle", "vessel"},
               "mavbridge": {"mavbridge", "vessel"}, "mission": {"mission", "vessel"}}
    wrong = {}
    for path in _modules():
        pkg = path.relative_to(ROOT).parts[0]
        extra = _imports(path) - allowed[pkg]
        if extra:
            wrong[str(path.relative_to(ROOT))] = sorted(extra)
    assert not wrong, wrong


def _top_level_imports(tree: ast.Module) -> list[ast.stmt]:
    """Module-level statements, including those under ``if TYPE_CHECKING:`` (a cycle in types is one too)."""
    out = []
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            out.extend(node.body)
        else:
            out.append(node)
    return out


def _module_graph() -> dict[str, set[str]]:
    """Module-level import edges between project modules (imports inside functions are deferred: not counted)."""
    names = {".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): p for p in _modules()}
    graph: dict[str, set[str]] = {}
    for name, path in names.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges = set()
        for node in _top_level_imports(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = package.split(".")
                if node.level:
                    base = base[:len(base) - node.level + 1]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                targets = [mod] + [f"{mod}.{a.name}" for a in node.names]
            edges |= {t for t in targets if t in names and t != name}
        graph[name] = edges
    return graph


def test_no_import_cycle() -> None:
    """No cycle among module-level imports (a package's __init__ re-exporting its modules excepted)."""
    graph = _module_graph()
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(node: str, stack: list[str]) -> bool:
        state[node] = 1
        for nxt in graph[node]:
            if nxt.startswith(node + ".") or node.startswith(nxt + "."):
                continue  # a package and its own submodules
            if state.get(nxt) == 1:
                cycle.extend([*stack[stack.index(nxt):], nxt] if nxt in stack else [node, nxt])
                return True
            if state.get(nxt) is None and visit(nxt, [*stack, nxt]):
                return True
        state[node] = 2
        return False

    for start in graph:
        if state.get(start) is None and visit(start, [start]):
            break
    assert not cycle, " -> ".join(cycle)
