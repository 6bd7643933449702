"""A seeded subset of the design suite (benchmarks/design_suite.py), for correctness only.

Each problem is solved by vsw.design and by the suite's reference, which does not use
IPOPT (a dense grid of the exact closed forms, then SciPy SLSQP). Times are not checked
here; benchmarks/run.py (case 8) reports them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import design_suite  # noqa: E402

from vsw import design as design_module  # noqa: E402

PROBLEMS = design_suite.make_suite(20, seed=7)


def test_the_subset_covers_every_kind_of_problem():
    labels = " ".join(p.label for p in PROBLEMS)
    for word in ("eigenvalue", "speed", "cost_of_transport", "target=None", "box=random",
                 "box=default", "infeasible"):  # fmt: skip
        assert word in labels, word
    targets = {t for p in PROBLEMS for t in p.targets}
    assert {"speed", "step_length", "step_frequency", "q_fixed"} <= targets


@pytest.mark.parametrize("problem", PROBLEMS, ids=[p.label[:3] for p in PROBLEMS])
def test_design_matches_or_beats_the_reference(problem):
    ref = design_suite.reference(problem, grid=24, polish=2)
    got = design_suite.solve(problem, design_module)
    verdict = design_suite.judge(problem, got, ref)
    assert verdict["success"], (problem.label, got, ref)
    if problem.feasible:
        assert got["status"] in ("optimal", "not-attained")
        assert got["violation"] <= design_suite.FEAS_TOL
        assert got["simulation_rel_error"] <= 1e-6
    else:
        assert got["status"] == "infeasible"
