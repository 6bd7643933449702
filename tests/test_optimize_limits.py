"""``vsw optimize`` under the run-time limit: targets no walker has are refused, a run the
estimate puts past the limit is refused before it starts, a NaN at IPOPT's start ends the
solve with the reason, and a stop that lands while CasADi builds the NLP or while IPOPT
runs ends the command within 2 s of the limit with one line (CasADi's own messages
dropped)."""

from __future__ import annotations

import contextlib
import io
import time

import numpy as np
import pytest

from vsw.cli import main
from vsw.cli.parser import EXIT_INPUT
from vsw.models import load
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.synthesis import powered
from vsw.synthesis.powered import problem, solve
from vsw.synthesis.powered import request as powered_request

BIPED_STABILITY = ["optimize", "--model", "free-vsw-biped-stop", "--minimize", "stability",
                   "--target-step-length", "0.5", "--json"]  # fmt: skip


def _run(argv: list[str], env: dict[str, str]) -> tuple[int, str, str, float]:
    out, err = io.StringIO(), io.StringIO()
    started = time.monotonic()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        with pytest.MonkeyPatch.context() as mp:
            for key, value in env.items():
                mp.setenv(key, value)
            code = main(argv)
    return code, out.getvalue(), err.getvalue(), time.monotonic() - started


@pytest.mark.parametrize(
    "option", ["--target-step-length=1e308", "--target-speed=1e4", "--target-period=inf",
               "--target-speed=nan", "--target-step-length=-1"],
)  # fmt: skip
def test_targets_beyond_any_walker_are_one_line(option):
    code, out, err, elapsed = _run(["optimize", "--model", "compass-gait", option], {})
    assert (code, out) == (EXIT_INPUT, "")
    assert err.count("\n") == 1 and "must be a positive number at most 1000" in err, err
    assert elapsed < 5


def test_a_run_the_estimate_puts_past_the_limit_is_refused_before_it_starts():
    code, out, err, elapsed = _run([*BIPED_STABILITY, "--nodes", "8"], {"VSW_MAX_SECONDS": "20"})
    assert (code, out) == (EXIT_INPUT, "")
    assert err.count("\n") == 1 and "optimizing eigenvalue on 8 and 16 intervals" in err, err
    assert "more than the limit of 20 s" in err and "--nodes" in err
    assert elapsed < 3


def test_the_estimate_lets_the_default_run_go_and_grows_with_the_work():
    compass = load("compass_gait")
    default = powered.estimate_seconds(compass, powered.Request())
    assert 1 < default < 60  # the compass gait's least squared torque takes about 2 s
    biped = load("free_vsw_biped_stop")
    one = powered.estimate_seconds(biped, powered.Request("stability", None, 0.5, 8))
    assert 120 < one < 1200  # measured: about 270 s
    three = powered.estimate_seconds(biped, powered.Request("stability", None, 0.5, 8, starts=3))
    assert three > 2 * one  # the solves of the second stage, three times


def test_a_start_where_the_nlp_is_not_finite_ends_the_solve_with_the_reason():
    """The same problem as a finite target, started from a guess with a NaN in it: IPOPT is
    not started, and the reason says why."""
    model = load("compass_gait")
    params = model.parameters()
    request = powered.Request()
    nlp = problem._build(model, request)
    guess = np.full(nlp.size, np.nan)
    with pytest.raises(ConvergenceError, match="not finite at its start"):
        solve._solve(model, params, request, nlp, guess)


@pytest.fixture
def no_estimate(monkeypatch):
    """The estimate out of the way: these runs are meant to meet the limit while they run."""
    monkeypatch.setattr(powered_request, "_check_cost", lambda model, request: None, raising=False)


def test_the_limit_stops_the_nlp_build_within_2_s(no_estimate):
    """At 8 intervals the stability NLP takes CasADi 4-7 s to build, after about 2 s of the
    first stage: a limit of 3 s lands in the build."""
    code, out, err, elapsed = _run([*BIPED_STABILITY, "--nodes", "8"], {"VSW_MAX_SECONDS": "3"})
    assert (code, out) == (EXIT_INPUT, "")
    assert err.count("\n") == 1 and err.startswith("vsw: error: stopped after 3"), err
    assert elapsed < 3 + 2, elapsed


def test_the_limit_inside_ipopt_is_one_line(no_estimate):
    """The stability solve at 4 intervals runs for tens of seconds after about 4 s of work
    before it: a limit of 7 s lands in IPOPT's iterations."""
    code, out, err, elapsed = _run([*BIPED_STABILITY, "--nodes", "4"], {"VSW_MAX_SECONDS": "7"})
    assert (code, out) == (EXIT_INPUT, "")
    assert err.count("\n") == 1 and err.startswith("vsw: error: stopped after 7"), err
    assert elapsed < 7 + 2, elapsed


def test_request_check_refuses_the_targets_from_python_too():
    with pytest.raises(VswInputError, match="at most 1000"):
        powered.Request(target_step_length=1e308).check()
    assert stop.reason() is None
