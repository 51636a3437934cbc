"""The preflight report: one finding per checked item (PASS, WARN or FAIL), printed as one table."""

from __future__ import annotations

from dataclasses import dataclass

PASS, WARN, FAIL = "PASS", "WARN", "FAIL"


@dataclass(frozen=True)
class Finding:
    """One line of the report: what was checked, what it should be, what it is, and how to fix it."""

    status: str
    item: str
    expected: str
    actual: str
    fix: str = ""


class Report:
    """The findings in the order they were made; any FAIL fails the check."""

    def __init__(self) -> None:
        self.findings: list[Finding] = []

    def add(self, status: str, item: str, expected: str, actual: str, fix: str = "") -> Finding:
        """Record a finding (a PASS carries no fix)."""
        finding = Finding(status, item, expected, actual, "" if status == PASS else fix)
        self.findings.append(finding)
        return finding

    @property
    def failed(self) -> bool:
        """True if any finding is a FAIL."""
        return any(f.status == FAIL for f in self.findings)

    def table(self) -> str:
        """A fixed-width table: status, check, expected, actual, fix; then the counts."""
        header = Finding("RESULT", "CHECK", "EXPECTED", "ACTUAL", "FIX")
        rows = [header, *self.findings]
        widths = [max(len(getattr(r, name)) for r in rows) for name in ("status", "item", "expected", "actual")]
        lines = []
        for r in rows:
            cells = [r.status, r.item, r.expected, r.actual]
            line = "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True))
            lines.append((line + "  " + r.fix).rstrip())
        counts = {s: sum(f.status == s for f in self.findings) for s in (PASS, WARN, FAIL)}
        lines.append(f"{counts[PASS]} passed, {counts[WARN]} warnings, {counts[FAIL]} failed")
        return "\n".join(lines)
