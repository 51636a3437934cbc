"""The cells of an Otter API CSV as numbers, a spreadsheet's dates read back, and nothing made up for the rest.

A file that went through a spreadsheet (Norwegian or English locale) has some numbers turned into dates, in two
forms: ``jan.45`` (month.year: 1.45 had no valid day.month reading) and ``04.feb`` (day.month: 4.2 — or 4.02,
which the spreadsheet shows alike). The first form has one reading (month + 0.digits). The second has two when
the month is jan..sep (``d.m`` or ``d.0m``): the cell's neighbours in its column decide — the reading nearest to
the value interpolated from up to two readable cells on each side (within ``NEIGHBOUR_S``), when it is clearly
nearer (``CLEAR``) than the other. A cell still unreadable (text that is no number, a date its neighbours do not
decide) is NaN: left out of every figure and counted per column, never replaced by 0.0.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from mavbridge.field.logs import plural

MONTHS = {"jan": 1, "feb": 2, "mar": 3, "apr": 4, "mai": 5, "may": 5, "jun": 6, "jul": 7, "aug": 8, "sep": 9,
          "okt": 10, "oct": 10, "nov": 11, "des": 12, "dec": 12}
YEAR_FORM = re.compile(r"^(-?)([A-Za-z]{3})\.(\d+)$")  # 'jan.45': month.digits
DAY_FORM = re.compile(r"^(-?)(\d{1,2})\.([A-Za-z]{3})$")  # '04.feb': whole.month
NEIGHBOUR_S = 1.0  # readable cells this close in time decide a day.month date's reading
CLEAR = 0.5  # the nearer reading is taken when at most this share of the other's distance from the neighbours


def readings(text: str) -> tuple[float, ...]:
    """What a cell can have been: () for an empty or unreadable cell, one value for a number or a date with one
    reading, two for a day.month date of jan..sep ('04.feb': 4.2 or 4.02)."""
    text = text.strip()
    if not text:
        return ()
    try:
        value = float(text)
    except ValueError:
        return _date(text)
    return (value,) if math.isfinite(value) else ()


def _date(text: str) -> tuple[float, ...]:
    found = YEAR_FORM.match(text)
    if found and found.group(2).lower() in MONTHS:
        value = MONTHS[found.group(2).lower()] + float(f"0.{found.group(3)}")
        return (-value if found.group(1) else value,)
    found = DAY_FORM.match(text)
    if found and found.group(3).lower() in MONTHS:
        sign = -1.0 if found.group(1) else 1.0
        whole, month = int(found.group(2)), MONTHS[found.group(3).lower()]
        if month >= 10:  # 'd.10' is never written for d.1 (that is 'd.jan'): one reading
            return (sign * (whole + month / 100),)
        return (sign * (whole + month / 10), sign * (whole + month / 100))
    return ()


@dataclass
class Column:
    """One column's values (NaN: empty or unreadable) and what reading it took."""

    name: str
    values: list[float] = field(default_factory=list)
    texts: dict[int, str] = field(default_factory=dict)  # row → the cell's text, for dates and unreadable cells
    choices: dict[int, tuple[float, ...]] = field(default_factory=dict)  # row → a day.month date's two readings
    counts: Counter[str] = field(default_factory=Counter)

    def add(self, text: str) -> None:
        """The next row's cell."""
        found = readings(text)
        row = len(self.values)
        stripped = text.strip()
        if len(found) == 2:
            self.choices[row] = found
            self.texts[row] = stripped
            self.values.append(math.nan)
            return
        self.values.append(found[0] if found else math.nan)
        if found and not _plain(stripped):
            self.counts["dates read back"] += 1
            self.texts.setdefault(-1, stripped)  # an example
        elif not found and stripped:
            self.counts["unreadable"] += 1
            self.texts[row] = stripped

    def decide(self, t: np.ndarray) -> None:
        """Each day.month date read by its neighbours (see the module docstring), NaN where they do not decide."""
        values = np.array(self.values, float)
        for row, (a, b) in self.choices.items():
            guess = _neighbours(t, values, row)
            near, far = (a, b) if guess is None or abs(a - guess) <= abs(b - guess) else (b, a)
            if guess is not None and abs(near - guess) <= CLEAR * abs(far - guess):
                self.values[row] = near
                self.counts["dates read back"] += 1
                self.texts.setdefault(-1, self.texts[row])
            else:
                self.counts["unreadable"] += 1

    def example(self) -> str:
        """A left-out cell's text, quoted."""
        bad = [text for row, text in self.texts.items() if row >= 0 and math.isnan(self.values[row])]
        return repr(bad[0]) if bad else ""


def _plain(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _neighbours(t: np.ndarray, values: np.ndarray, row: int) -> float | None:
    """The value at ``row`` interpolated from up to two readable cells each side within NEIGHBOUR_S (a cubic
    through four, a line through two, the one cell when only one is there); None without any."""
    near = np.flatnonzero(np.isfinite(values) & (np.abs(t - t[row]) <= NEIGHBOUR_S))
    before, after = near[near < row][-2:], near[near > row][:2]
    if not before.size or not after.size:
        return float(values[before[-1]]) if before.size else float(values[after[0]]) if after.size else None
    if before.size < 2 or after.size < 2:
        before, after = before[-1:], after[:1]
    index = np.concatenate([before, after])
    coefficients = np.polyfit(t[index] - t[row], values[index], index.size - 1)
    return float(coefficients[-1])


def column_notes(columns: list[Column], labels: dict[str, str]) -> list[str]:
    """One line per column with cells left out; one for the dates read back (with an example)."""
    notes = []
    for column in columns:
        n = column.counts["unreadable"]
        if n:
            notes.append(f"{labels.get(column.name, column.name)}: {plural(n, 'cell')} unreadable, left out "
                         f"(e.g. {column.example()})")
    dates = sum(c.counts["dates read back"] for c in columns)
    if dates:
        example = next(c.texts[-1] for c in columns if -1 in c.texts)
        notes.append(f"{plural(dates, 'number')} a spreadsheet had turned into dates read back (e.g. {example!r}; a "
                     "day.month date such as '04.feb', 4.2 or 4.02, by its neighbours in the column)")
    return notes
