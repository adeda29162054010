"""The stability cases (texbake.checks.stability) as tests, and the ``texbake stability`` command.

Every registered case is a test. The slow one (the 16384² bake, minutes) carries the
``slow`` marker and is left out of the default run; ``.ci/run`` runs every case as a user
does, ``scripts/run texbake stability``. The cases on real xatlas failures (``xatlas-*``:
a hang on an infinite vertex, the crash on icosphere(6) and the unwrap that must follow
it) take seconds and run by default, marked ``xatlas_failure``: a new xatlas that no
longer hangs or crashes there fails them, and they must then find another input.
"""

import json
import math

import pytest
from conftest import run_cli

from texbake.checks import stability
from texbake.cli import main


def _marks(c: stability.Case) -> list:
    marks = [pytest.mark.slow] if c.slow else []
    return [*marks, pytest.mark.xatlas_failure] if c.name.startswith("xatlas-") else marks


CASES = [pytest.param(c, id=c.name, marks=_marks(c)) for c in stability.CASES.values()]


@pytest.mark.parametrize("case", CASES)
def test_case_passes(case):
    r = stability.run_case(case)
    assert r.passed, f"{r.case}: {r.property}: {r.figure} {r.comparison} {r.limit} failed ({r.detail})"
    assert r.case == case.name and r.slow == case.slow and not r.skipped


def _figure_above_its_limit():
    return stability.Figure(1.0, 0.5, "measured 1.0 against 0.5")


def _raises():
    return 1 / 0


@pytest.fixture
def broken(monkeypatch):
    """Two real cases that fail: one over its limit, one raising."""
    monkeypatch.setitem(stability.CASES, "injected-over-limit",
                        stability.Case("injected-over-limit", "a figure over its limit", _figure_above_its_limit))
    monkeypatch.setitem(stability.CASES, "injected-raises", stability.Case("injected-raises", "a case that raises", _raises))
    monkeypatch.setenv("COLUMNS", "250")


def test_failures_and_exceptions_are_results(broken):
    over, raised = stability.run_cases(select="injected")
    assert not over.passed and over.figure == 1.0 and over.limit == 0.5
    assert not raised.passed and math.isnan(raised.figure)
    assert "ZeroDivisionError" in raised.detail and "division by zero" in raised.detail


def test_quick_skips_slow_cases_and_select_filters():
    slow = [c.name for c in stability.CASES.values() if c.slow]
    assert slow == ["image-16384"]
    results = stability.run_cases(quick=True, select=slow + ["signed-zero"])
    skipped = [r.case for r in results if r.skipped]
    assert skipped == slow and all(r.passed for r in results)
    assert [r.case for r in results if not r.skipped] == ["signed-zero"]
    assert stability.selected("no-such-case") == []


def test_command_exits_1_on_a_failing_case_and_prints_the_table(broken, capsys):
    code = main(["stability", "--quick", "--case", "injected", "--case", "signed-zero"])
    out, err = capsys.readouterr()
    assert code == 1
    for column in ("case", "property", "figure", "limit", "result"):
        assert column in out
    assert "injected-over-limit" in out and "fail" in out and "pass" in out and "ZeroDivisionError" in out
    assert "2 of 3 stability cases failed" in err and "Traceback" not in out + err


def test_command_json(broken, capsys):
    code = main(["stability", "--json", "--case", "injected-over"])
    rows = json.loads(capsys.readouterr().out)
    assert code == 1 and [r["case"] for r in rows] == ["injected-over-limit"]
    assert rows[0]["passed"] is False and rows[0]["figure"] == 1.0 and rows[0]["limit"] == 0.5


def test_command_passes_with_exit_0_and_usage_errors_exit_2():
    r = run_cli("stability", "--quick", "--case", "signed-zero", "--case", "image-16384")
    assert r.returncode == 0, r.stderr
    assert "signed-zero" in r.stdout and "pass" in r.stdout and "skipped" in r.stdout
    for column in ("case", "property", "figure", "limit", "result"):
        assert column in r.stdout
    for args in (["--case", "no-such-case"], ["--quik"]):
        bad = run_cli("stability", *args)
        assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1, bad.stderr
