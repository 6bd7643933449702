"""The ILE as a hybrid zero dynamics (derive.hzd's symbolic reduction on the point-mass
biped, paper_check/hzd_ile.py), against the pendulum's physics worked out here by hand:

* on each piece of the step ``sigma = m r^2 theta_dot`` and ``d sigma/dt = m g r sin
  theta`` (an inverted pendulum of length ``r``), so ``V(theta_IV) = -m^2 g (r_s^3 (cos
  theta_I - cos theta_II) + r_c^3 (cos theta_II - cos theta_IV))``;
* at heelstrike the hip's velocity ``r_c theta_dot`` is perpendicular to the stance leg
  and has the moment arm ``r_s cos phi0`` about the new foot: ``delta = beta cos phi0``,
  the printed (19) in :mod:`paper_check.equations`;
* constraints the reduction must refuse: an input with a moment about the stance foot, and
  a step that the inputs' impulse cannot make.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import sympy as sm

from derive.hzd import (
    THETA,
    Constraints,
    ConstraintsError,
    Step,
    coordinates,
    reduce,
    restricted_map,
)
from derive.models.point_mass_biped_switch import MODEL
from paper_check.equations import EQUATION_BY_ID, PAPER_SYMBOLS
from paper_check.ile_hzd_constraints import CONSTRAINTS

x, y = coordinates("x", "y")
M, G, L, D, L_MIN, SIGMA = (p.symbol for p in MODEL.parameters)
T1, T4 = sm.symbols("theta_I theta_IV", real=True)
T2 = sm.Symbol("theta_II", real=True)


@pytest.fixture(scope="module")
def reduced():
    own = {**CONSTRAINTS.parameters, "theta_I": None, "theta_IV": None}
    at = dataclasses.replace(CONSTRAINTS, theta_plus=T1, theta_minus=T4, parameters=own)
    return reduce(MODEL, at)


def _same(a: sm.Expr, b: sm.Expr) -> bool:
    return sm.simplify(sm.expand_trig(a - b)) == 0


def test_each_piece_is_an_inverted_pendulum_of_its_leg(reduced):
    s = reduced.symbols
    assert [str(b) for b in reduced.breaks] == ["theta_I", "theta_II", "theta_IV"]
    for inertia, moment, r in zip(reduced.inertia, reduced.moment, (L_MIN, L)):
        assert _same(inertia, M * r**2)
        assert _same(moment, M * G * r * sm.sin(THETA))
    assert s["theta_II"].name == "theta_II"


def test_the_potential_is_the_two_pendulums_work(reduced):
    _, v = restricted_map(reduced)
    t2 = reduced.symbols["theta_II"]
    by_hand = -M**2 * G * (L_MIN**3 * (sm.cos(T1) - sm.cos(t2))
                           + L**3 * (sm.cos(t2) - sm.cos(T4)))  # fmt: skip
    assert _same(v.xreplace({reduced.symbols["theta_I"]: T1,
                             reduced.symbols["theta_IV"]: T4}), by_hand)  # fmt: skip


def test_delta_squared_is_the_printed_eigenvalue_19(reduced):
    """With the ILE's geometry (5) the derived delta^2 is (19), beta^2 cos^2 phi0."""
    geometry = {L_MIN: L * sm.cos(T4) / sm.cos(T1)}
    geometry[D] = L * sm.sin(T4) - geometry[L_MIN] * sm.sin(T1)
    geometry[SIGMA] = L * sm.sin(T4) / geometry[D]
    swap = {reduced.symbols["theta_I"]: T1, reduced.symbols["theta_IV"]: T4}
    delta2 = (reduced.delta**2).xreplace(swap).xreplace(geometry)
    p = PAPER_SYMBOLS
    printed = (
        EQUATION_BY_ID["(19)"]
        .parsed[0]
        .rhs.xreplace({p["beta"]: sm.cos(T4) / sm.cos(T1), p["varphi_0"]: T4 - T1})
    )
    assert _same(delta2, printed)


def test_the_file_s_section_angles_are_theta_I_and_theta_IV_of_the_paper():
    """theta_plus and theta_minus as the file writes them, at the model's parameters of the
    ILE's step, are (11)'s theta_I and theta_I + phi0."""
    from paper_check.hzd_ile import switch_parameters

    for beta, phi0 in ((0.8, math.pi / 4), (0.95, 0.4), (0.6, 1.2)):
        sw = switch_parameters(beta, phi0, 1.3)
        values = {L: sw["l"], L_MIN: sw["l_min"], D: sw["d"], SIGMA: sw["sigma"]}
        theta_1 = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))
        plus = float(sm.sympify(CONSTRAINTS.theta_plus).subs(values))
        minus = float(sm.sympify(CONSTRAINTS.theta_minus).subs(values))
        assert plus == pytest.approx(theta_1, abs=1e-13)
        assert minus == pytest.approx(theta_1 + phi0, abs=1e-13)


def test_an_input_with_a_moment_about_the_foot_is_refused():
    both = dataclasses.replace(CONSTRAINTS, inputs=())
    with pytest.raises(ConstraintsError, match="one output per input"):
        reduce(MODEL, both)
    torque = dataclasses.replace(CONSTRAINTS, inputs=("stance_torque",))
    with pytest.raises(ConstraintsError, match="torque about the stance foot"):
        reduce(MODEL, torque)


def test_a_step_across_the_leg_is_refused():
    """A jump of the hip sideways at a fixed height: the leg force cannot make it."""
    sideways = Constraints(phase=y, theta_plus=0.9, theta_minus=0.8,
                           outputs={x: Step(at=0.85, before=-0.1, after=0.1)},
                           inputs=("leg_force",))  # fmt: skip
    with pytest.raises(ConstraintsError, match="impulse cannot"):
        reduce(MODEL, sideways)
    radial = Constraints(phase=sm.atan2(x, y), theta_plus=-0.3, theta_minus=0.3,
                         outputs={x: Step(at=0.0, before=-0.1, after=0.1)},
                         inputs=("leg_force",))  # fmt: skip
    with pytest.raises(ConstraintsError, match="affine"):
        reduce(MODEL, radial)


def test_a_wrong_inverse_is_refused():
    from derive.hzd import value

    wrong = dataclasses.replace(CONSTRAINTS, inverse={x: value(0) * sm.cos(THETA),
                                                      y: value(0) * sm.sin(THETA)})  # fmt: skip
    with pytest.raises(ConstraintsError, match="does not invert"):
        reduce(MODEL, wrong)


def test_the_runtime_refuses_what_it_cannot_carry():
    from derive.hzd import derivation

    with pytest.raises(ConstraintsError, match="restricted_map"):
        derivation(MODEL, CONSTRAINTS, "hzd")


@pytest.mark.slow
def test_the_audit_section_s_identities_and_numbers():
    """The whole section: every residual simplified to zero and the numbers within 1e-12
    of the printed forms and of the generated ILE."""
    from paper_check.hzd_ile import numeric_check, symbolic_check

    assert all(v == 0 for v in symbolic_check()["residuals"].values())
    worst = numeric_check(50)["largest relative difference"]
    assert max(worst.values()) <= 1e-12, worst
    assert np.isfinite(list(worst.values())).all()


def test_the_runtime_s_impact_and_quadrature_give_the_ile_s_map():
    """The point-mass biped's generated impact from the surface at theta_IV and the
    runtime's quadrature of kappa: the ILE's closed forms to 1e-9."""
    from paper_check.hzd_ile import runtime_check

    worst = runtime_check(10)["largest relative difference"]
    assert len(worst) == 5 and max(worst.values()) <= 1e-9, worst


def test_vsw_hzd_refuses_the_file_in_one_line(tmp_path):
    """The runtime cannot carry the configuration's jump: one line on stderr, exit 2."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    done = subprocess.run(
        [sys.executable, "-m", "vsw", "hzd", "--model", "point-mass-biped-switch",
         "--constraints", str(root / "paper_check" / "ile_hzd_constraints.py")],
        capture_output=True, text=True, cwd=root, timeout=600,
        env={**os.environ, "VSW_CACHE_DIR": str(tmp_path)},
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Step" in done.stderr
