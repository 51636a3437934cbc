"""The suite's order for xdist (tests/expected_durations.py): every test once, slow ones dealt to slice heads."""

from __future__ import annotations

from pathlib import Path

from tests.expected_durations import balanced_order, durations_file, read_expected, slice_sizes


def test_slices_are_the_sizes_worksteal_hands_out() -> None:
    assert slice_sizes(10, 3) == [3, 3, 4]
    assert slice_sizes(1450, 3) == [483, 483, 484]
    assert sum(slice_sizes(7, 4)) == 7 and slice_sizes(2, 3) == [0, 1, 1]


def test_each_worker_starts_with_its_share_of_the_slow_tests() -> None:
    ids = [f"t{i}" for i in range(30)]
    expected = {"t29": 60.0, "t28": 50.0, "t27": 40.0, "t3": 30.0, "t26": 10.0}
    order = balanced_order(ids, expected, 3)
    assert sorted(order) == sorted(ids)  # nothing dropped or repeated
    slices = [order[0:10], order[10:20], order[20:30]]
    assert [s[0] for s in slices] == ["t29", "t28", "t27"]  # the three longest open the three slices
    heads = [[t for t in s if t in expected] for s in slices]
    assert [sum(expected[t] for t in h) for h in heads] == [60.0, 60.0, 70.0]  # t3, then t26, to the lightest
    for s, head in zip(slices, heads, strict=True):
        assert s[:len(head)] == head  # the slow ones first in each slice
        rest = [int(t[1:]) for t in s[len(head):]]
        assert rest == sorted(rest)  # the others in file order


def test_one_worker_runs_the_slow_tests_first_and_unknown_ones_in_file_order() -> None:
    assert balanced_order(["a", "b", "c", "d"], {"c": 9.0, "zz": 99.0}, 1) == ["c", "a", "b", "d"]
    assert balanced_order(["a", "b"], {}, 3) == ["a", "b"]


def test_the_file_is_made_from_a_durations_report_and_read_back(tmp_path: Path) -> None:
    report = ["12.50s call     tests/x.py::test_a", "1.20s setup    tests/x.py::test_a",
              "3.00s call     tests/x.py::test_b", "(10 durations < 0.005s hidden)"]
    path = tmp_path / "durations.txt"
    path.write_text(durations_file(report))
    assert read_expected(path) == {"tests/x.py::test_a": 14.0}  # 13.7 s rounded; test_b below the cut
    assert read_expected(tmp_path / "missing.txt") == {}


def test_the_shipped_file_names_tests_that_exist() -> None:
    root = Path(__file__).resolve().parents[1]
    expected = read_expected()
    assert len(expected) >= 20
    for test in expected:
        assert (root / test.split("::")[0]).exists(), test
