"""A stratified subset of the design suite (benchmarks/design_suite.py), for correctness.

Each problem is solved by vsw.models.ile.design and by the suite's reference, which does not use
IPOPT (a dense grid of the exact closed forms, then SciPy SLSQP from the best grid points
and from the gait the problem was built from). Times are not checked here;
benchmarks/run.py (case 8) reports them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import design_suite  # noqa: E402

from vsw.models.ile import design as design_module  # noqa: E402

PROBLEMS = design_suite.subset(design_suite.make_suite(220, 2026))


def test_the_subset_covers_every_kind_of_problem():
    feasible = [p for p in PROBLEMS if p.feasible]
    assert {p.objective for p in feasible} == {"eigenvalue", "speed", "cost_of_transport"}
    targets = {next(iter(p.targets), None) for p in feasible}
    assert targets == {"speed", "step_length", "step_frequency", "q_fixed", None}
    assert any(p.bounds for p in feasible) and any(not p.bounds for p in feasible)
    assert any(p.min_contact_margin > 0 for p in feasible)
    kinds = {(p.conflict, p.beyond) for p in PROBLEMS if not p.feasible}
    assert kinds == {
        (name, beyond)
        for name in ("max_eigenvalue", "target_step_length", "min_contact_margin")
        for beyond in (1.001, 1.5)
    }


@pytest.mark.slow
@pytest.mark.parametrize("problem", PROBLEMS, ids=[p.label[:3] for p in PROBLEMS])
def test_design_matches_or_beats_the_reference(problem):
    ref = design_suite.reference(problem, grid=24, polish=2)
    got = design_suite.solve(problem, design_module)
    verdict = design_suite.judge(problem, got, ref)
    assert verdict["success"], (problem.label, got, ref)
    if problem.feasible:
        # The witness the problem was built from is feasible: the reference always exists.
        assert ref["objective"] is not None
        assert got["status"] in ("optimal", "not-attained")
        assert got["violation"] <= design_suite.FEAS_TOL
        assert got["simulation_rel_error"] <= 1e-6
        if got["status"] == "not-attained":
            assert design_suite.check_path(problem, got, grid=24) in (True, None)
    else:
        assert got["status"] == "infeasible"
        assert problem.conflict in got["conflicting"]
