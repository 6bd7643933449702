"""Every edge of every parameter has a tested answer.

A parameter's table gives its open interval and, where vsw cannot compute the whole of it,
the closed interval it computes (``computed``, with the reason: a scale within 1e6 of its
default, and the ends found to underflow, overflow or stiffen). At each edge the answer is
a result, exit 3 with the reason, or a one-line refusal, never a traceback or a warning;
beyond what is computed the refusal says why. The cases the command-line fuzz found are
here by name.
"""

from __future__ import annotations

import contextlib
import io
import math
import warnings

import numpy as np
import pytest

from vsw.cli import main
from vsw.models import keys, load


def run(argv, max_seconds="3"):
    out, err = io.StringIO(), io.StringIO()
    with (
        pytest.MonkeyPatch.context() as mp,
        warnings.catch_warnings(),
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        warnings.simplefilter("error")  # any warning is a defect here
        mp.setenv("VSW_MAX_SECONDS", max_seconds)
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def one_line(err: str) -> str:
    assert err.endswith("\n") and err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip()


def edges():
    """(model, parameter) of every model's table."""
    for key in keys():
        model = load(key)
        for p in model.parameter_table:
            yield pytest.param(model.cli_name, p, id=f"{model.cli_name}-{p.name}")


@pytest.mark.parametrize(("model", "p"), list(edges()))
def test_the_open_bounds_are_refused(model, p):
    for bound in (p.lower, p.upper):
        if not math.isfinite(bound):
            continue
        code, out, err = run(["analyze", "--model", model, "--param", f"{p.name}={bound!r}"])
        assert code == 2 and out == ""
        assert "open interval" in one_line(err)


@pytest.mark.parametrize(("model", "p"), list(edges()))
def test_beyond_what_is_computed_is_refused_with_the_reason(model, p):
    computed = p.computed
    if computed is None:
        pytest.skip(f"{model} computes all of {p.name}'s interval")
    low, high = computed
    beyond = [v for v in (low * (1 - 1e-9) if low > 0 else low - 1e-9, high * (1 + 1e-9))
              if p.lower < v < p.upper]  # fmt: skip
    assert beyond, "a computed interval narrower than the table's has a side beyond it"
    for value in beyond:
        code, out, err = run(["analyze", "--model", model, "--param", f"{p.name}={value!r}"])
        assert code == 2 and out == ""
        line = one_line(err)
        assert "the values vsw computes for it" in line and p.computed_reason in line


@pytest.mark.parametrize("model", ["ile", "tle", "rimless-wheel"])
def test_closed_form_models_answer_at_every_computed_edge(model):
    """The models with a closed-form stride map answer at once at both ends of every
    parameter's computed interval (just inside the open bounds where it is all of it)."""
    for p in load(model).parameter_table:
        low, high = p.computed or (p.lower, p.upper)
        for value in (low, high):
            if value == p.lower:
                value = float(np.nextafter(value, math.inf))
            if value == p.upper:
                value = float(np.nextafter(value, -math.inf))
            code, out, err = run(
                ["analyze", "--model", model, "--param", f"{p.name}={value!r}", "--json"], "20"
            )
            assert code in (0, 3), f"{p.name}={value!r}: exit {code}: {err}"
            if code == 3:
                one_line(err)
            else:
                assert err == "" and out.startswith("{")


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "--model", "vsw-biped", "--param", "mu=1e300"],
        ["analyze", "--model", "vsw-biped", "--param", "mu=5e-324"],
        ["analyze", "--model", "vsw-biped", "--param", "b_over_l=1e-12"],
        ["analyze", "--model", "compass-gait", "--param", "m_h=1e300"],
        ["analyze", "--model", "compass-gait", "--param", "m=1e300"],
        ["analyze", "--model", "compass-gait", "--param", "a=1e300"],
        ["analyze", "--model", "compass-gait", "--param", "b=1e100"],
        ["analyze", "--model", "tle", "--param", "delta=1e-300"],
        ["analyze", "--model", "tle", "--param", "beta=5e-324"],
        ["sweep", "--model", "compass-gait", "--over", "a=0.6255:1e308:5"],
        ["basin", "--model", "rimless-wheel", "--grid", "theta_dot=-1e308:1e308:3"],
    ],
    ids=lambda argv: " ".join(argv[1:]),
)
def test_the_fuzz_cases_are_refused_in_one_line(argv):
    """Issue 21's tracebacks (OverflowError, ZeroDivisionError), numpy warnings and runs of
    minutes: each is now a one-line refusal at once."""
    code, out, err = run(argv)
    assert code == 2 and out == ""
    one_line(err)


def test_tle_near_its_computed_edges_is_a_physical_answer():
    """Before, beta = 1e-300 raised ZeroDivisionError in the generated closed forms (Python
    floats); at the computed edge beta = 1e-12 the closed forms are finite and say why
    there is no gait: the leg must pull (q^f grows as 1/beta^2)."""
    code, out, err = run(["analyze", "--model", "tle", "--param", "beta=1e-12", "--json"], "20")
    assert code == 0, err
    import json

    data = json.loads(out)
    conditions = data["closed_form"]["conditions"]
    assert all(math.isfinite(c["margin"]) for c in conditions)
    assert data["closed_form"]["q_fixed"] == pytest.approx(1.1494e24, rel=1e-3)
    assert not data["fixed_points"]


def test_slow_edges_stop_at_the_limit_in_one_line():
    """Inside what is computed, a leg mass near the hip makes the compass gait's swing
    stiff: its gait search takes minutes. The limit stops it, in one line."""
    code, out, err = run(["analyze", "--model", "compass-gait", "--param", "b=1e-3"], "2")
    assert code == 2 and out == ""
    assert "past the run-time limit of 2 s" in one_line(err)
