"""The finite-time leg extension (TLE) model: its closed forms against the engine's generic
runtime (BVP orbit, simulation), the actuator's work integrated along the motion, the leg
force and ground contact, the limit delta -> 0 (the ILE's (10), (19), (20)), the numpy and
CasADi backends, and the engine pieces the model needs (continuous transitions)."""

from __future__ import annotations

import dataclasses
import inspect
import math

import mpmath as mp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import generated.ile as ile
import generated.tle as tle
from vsw.models import load

DEFAULT = (0.93, -0.1, 0.7, 0.4)
GAITS = [DEFAULT, (0.95, 0.0, 0.6, 0.3), (0.9, -0.15, 0.8, 0.5)]
"""Parameter sets (beta, theta_II, phi0, delta) at which every condition holds."""
TENSILE = (0.93, -0.1, 0.7, 0.1)
"""A fast extension: the leg would have to pull to stop it (leg_compressive < 0)."""


@pytest.fixture(scope="module")
def model():
    return load("tle")


def margins(params) -> dict[str, float]:
    out = tle.fixed_point_conditions(*params)
    return {k: float(v) for k, v in zip(tle.fixed_point_conditions.outputs, out)}


def section_state(params, q: float) -> np.ndarray:
    return np.array([tle.theta_I(params[0], params[2]), math.sqrt(q)])


def test_default_parameters_walk():
    m = margins(DEFAULT)
    assert all(m[name] > 0 for name in ("q_positive", "apex", "extension_reached",
                                        "extension_completed", "leg_compressive",
                                        "stance_contact"))  # fmt: skip
    assert [c[0] for c in tle.CONDITIONS] == list(tle.fixed_point_conditions.outputs[2:])
    assert {c[3] for c in tle.CONDITIONS} == {"exact", "sampled"}


# --- closed form against the generic runtime -------------------------------------------------


@pytest.mark.parametrize("params", GAITS)
def test_closed_form_fixed_point_is_the_bvp_orbit(model, params):
    q_f = float(tle.q_fixed(*params))
    durations = model.step(params, section_state(params, q_f)).durations
    guess = section_state(params, 1.03 * q_f) + np.array([0.01, 0.0])
    orbit = model.periodic_orbit(params, guess, np.array(durations) * 1.02)
    assert orbit.state["theta"] == pytest.approx(tle.theta_I(params[0], params[2]), rel=1e-9)
    assert orbit.state["theta_dot"] ** 2 == pytest.approx(q_f, rel=1e-9)
    # The section angle is fixed, so the map's Jacobian has eigenvalues lambda and 0.
    lam = float(tle.eigenvalue(*params))
    assert abs(orbit.eigenvalues[0]) == pytest.approx(lam, rel=1e-8)
    assert abs(orbit.eigenvalues[1]) < 1e-8
    assert lam == pytest.approx(params[0] ** 2 * math.cos(params[2]) ** 2, rel=1e-15)


def test_runtime_scan_finds_the_closed_form_gait(model):
    orbits = model.fixed_points(model.parameters({}))
    assert len(orbits) == 1
    q_f = float(tle.q_fixed(*DEFAULT))
    assert orbits[0].state["theta_dot"] ** 2 == pytest.approx(q_f, rel=1e-9)
    assert orbits[0].step_length == pytest.approx(
        math.sin(tle.theta_IV(DEFAULT[0], DEFAULT[2])) - DEFAULT[0] * math.sin(
            tle.theta_I(DEFAULT[0], DEFAULT[2])), rel=1e-9)  # fmt: skip


@pytest.mark.parametrize("params", GAITS)
def test_simulated_step_is_the_stride_map(model, params):
    q_f = float(tle.q_fixed(*params))
    for q in (q_f, 0.9 * q_f, 1.03 * q_f):
        # The closed form says the foot stays down, so the simulation completes the step.
        assert float(tle.contact_margin(*params, q)) > 0
        step = model.step(params, section_state(params, q))
        assert step.ended == "completed"
        assert step.state[0] == pytest.approx(tle.theta_I(params[0], params[2]), rel=1e-10)
        assert step.state[1] ** 2 == pytest.approx(float(tle.stride_map(*params, q)), rel=1e-9)


def test_energy_is_constant_in_the_unforced_phases(model):
    params = DEFAULT
    q = 1.1 * float(tle.q_fixed(*params))
    traj = model.simulate(params, section_state(params, q), steps=2)
    assert traj.ended == "completed"
    names = [p["name"] for p in model.phases]
    checked, extensions = 0, 0
    boundaries = np.flatnonzero(np.diff(traj.phase)) + 1
    for segment in np.split(np.arange(len(traj.t)), boundaries):
        phase = names[traj.phase[segment[0]]]
        energies = np.array([model.energy(phase, params, traj.states[k]) for k in segment])
        if phase == "extension":
            # The actuator adds the closed-form energy input of this step's q.
            q_step = traj.section[extensions][1] ** 2
            gain = energies[-1] - energies[0]
            assert gain == pytest.approx(float(tle.energy_input(*params, q_step)), rel=1e-9)
            extensions += 1
            continue
        assert np.ptp(energies) < 1e-10 * max(1.0, np.max(np.abs(energies)))
        checked += 1
    assert (checked, extensions) == (4, 2)


# --- the extension: h**2, actuator work, leg force -------------------------------------------


def integrate_extension(params, q: float, events=()):
    """The extension phase integrated with the generated dynamics, with the actuator's work
    W' = F dr/dt (F the generated leg force, dr/dt = r'(theta) omega) as a third state."""
    beta, theta_II, _, delta = params
    omega_II = math.sqrt(float(tle.extension_h_squared(*params, q, 0.0))) / beta**2

    def rhs(_t, x):
        theta, omega, _work = x
        (acc,) = tle.extension_accelerations(*params, theta, omega)
        _, dr, _ = tle.extension_profile(beta, theta_II, delta, theta)
        force = tle.extension_leg_force(*params, theta, omega)
        return [omega, acc, force * dr * omega]

    def end(_t, x):
        return x[0] - theta_II - delta

    end.terminal = True
    return solve_ivp(rhs, (0, 50), [theta_II, omega_II, 0.0], method="DOP853", rtol=1e-12,
                     atol=1e-13, events=[end, *events], dense_output=True)  # fmt: skip


@pytest.mark.parametrize("params", GAITS)
def test_actuator_work_is_the_energy_input(params):
    for q in (float(tle.q_fixed(*params)), 0.3):
        sol = integrate_extension(params, q)
        work = sol.y_events[0][0][2]
        assert work == pytest.approx(float(tle.energy_input(*params, q)), rel=1e-9)
        # And h**2 = (r**2 omega)**2 at the end is the closed form's.
        omega_end = sol.y_events[0][0][1]
        assert omega_end**2 == pytest.approx(
            float(tle.extension_h_squared(*params, q, 1.0)), rel=1e-10
        )


def test_energy_balance_at_the_fixed_point():
    for params in GAITS:
        q_f = float(tle.q_fixed(*params))
        assert float(tle.energy_input(*params, q_f)) == pytest.approx(
            float(tle.energy_dissipated(*params, q_f)), rel=1e-12
        )


def test_h_squared_and_leg_force_along_the_extension():
    params = DEFAULT
    beta, theta_II, _, delta = params
    q = float(tle.q_fixed(*params))
    sol = integrate_extension(params, q)
    t_end = sol.t_events[0][0]
    for t in np.linspace(0, t_end, 9):
        theta, omega, _ = sol.sol(t)
        x = (theta - theta_II) / delta
        r, _, _ = tle.extension_profile(beta, theta_II, delta, theta)
        assert (r**2 * omega) ** 2 == pytest.approx(
            float(tle.extension_h_squared(*params, q, x)), rel=1e-10
        )
        assert float(tle.extension_leg_force(*params, theta, omega)) == pytest.approx(
            float(tle.extension_leg_force_at(*params, q, x)), rel=1e-9, abs=1e-12
        )


def test_apex_margin_is_h_squared_at_the_apex():
    # theta = 0 lies inside the default extension: the margin is h**2 there.
    params = DEFAULT
    q = float(tle.q_fixed(*params))

    def apex(_t, x):
        return x[0]

    sol = integrate_extension(params, q, events=(apex,))
    theta_0, omega_0, _ = sol.y_events[1][0]
    r, _, _ = tle.extension_profile(params[0], params[1], params[3], theta_0)
    assert (r**2 * omega_0) ** 2 == pytest.approx(margins(params)["apex"], rel=1e-10)


@pytest.mark.parametrize("params", [*GAITS, TENSILE])
def test_sampled_leg_force_minimum_against_a_dense_one(params):
    q = float(tle.q_fixed(*params))
    dense = np.asarray(tle.extension_leg_force_at(*params, q, np.linspace(0, 1, 2001)))
    sampled = margins(params)["leg_compressive"]
    scale = np.max(np.abs(dense))
    assert sampled >= dense.min() - 1e-12 * scale
    assert sampled - dense.min() < 2e-3 * scale
    assert (sampled >= 0) == (dense.min() >= 0)


def test_fast_extension_pulls_and_the_foot_lifts_off(model):
    """Where the leg force margin is negative the generic simulation (which knows only the
    ground reaction) loses the ground exactly where the leg force first turns tensile."""
    params = TENSILE
    _, theta_II, _, delta = params
    q = float(tle.q_fixed(*params))
    assert margins(params)["leg_compressive"] < 0
    step = model.step(params, section_state(params, q))
    assert step.ended == "lift-off"
    first_zero = brentq(lambda x: float(tle.extension_leg_force_at(*params, q, x)), 0.0, 1.0,
                        xtol=1e-14)  # fmt: skip
    assert (step.state[0] - theta_II) / delta == pytest.approx(first_zero, abs=1e-8)
    for params in GAITS:
        assert model.step(params, section_state(params, float(tle.q_fixed(*params)))).ended == (
            "completed"
        )


@pytest.mark.parametrize("params", GAITS)
def test_stance_contact_against_a_dense_minimum(params):
    """The exact contact minimum of the constant-length phases against the generated normal
    force on a dense integration of each phase."""
    beta, theta_II, phi0, delta = params
    q = float(tle.q_fixed(*params))
    theta_I, theta_IV = tle.theta_I(beta, phi0), tle.theta_IV(beta, phi0)
    omega_III = math.sqrt(float(tle.extension_h_squared(*params, q, 1.0)))
    lows = []
    for phase, start, end in (("short", (theta_I, math.sqrt(q)), theta_II),
                              ("long", (theta_II + delta, omega_III), theta_IV)):  # fmt: skip

        def rhs(_t, x, phase=phase):
            return [x[1], getattr(tle, f"{phase}_accelerations")(*params, *x)[0]]

        def stop(_t, x, end=end):
            return x[0] - end

        stop.terminal = True
        sol = solve_ivp(rhs, (0, 50), list(start), rtol=1e-12, atol=1e-13, events=stop,
                        dense_output=True)  # fmt: skip
        states = sol.sol(np.linspace(0, sol.t_events[0][0], 4001))
        lows.append(np.min(getattr(tle, f"{phase}_normal_force")(*params, *states)))
    assert margins(params)["stance_contact"] == pytest.approx(min(lows), abs=1e-7)
    assert float(tle.contact_margin(*params, q)) <= min(lows) + 1e-7


# --- delta -> 0: the ILE ---------------------------------------------------------------------


def test_limit_is_the_ile_symbolically():
    """The Taylor coefficients of order 0 are the paper's (10) and (20) (theta_1 from (11));
    the eigenvalue is (19) for every delta; the rate is O(delta), O(delta**2) at
    theta_II = 0."""
    import sympy as sm

    from derive.models import tle as tle_model
    from paper_check.equations import EQUATION_BY_ID
    from paper_check.equations import PAPER_SYMBOLS as S

    lim = tle_model.ile_limit()
    c = sm.Symbol("c", positive=True)
    ours = {
        tle_model.beta: S["beta"],
        tle_model.theta_II: S["theta_II"],
        tle_model.phi0: S["varphi_0"],
        tle_model.cos_I: c,
        tle_model.cos_IV: S["beta"] * c,
    }  # fmt: skip (cos theta_IV from the guard (5))
    paper = {sm.cos(S["theta_1"]): c, sm.cos(S["theta_I"]): c}
    q10 = EQUATION_BY_ID["(10)"].expr.rhs.xreplace(paper)
    assert sm.cancel(lim["q0"].xreplace(ours) - q10) == 0
    e20 = (
        EQUATION_BY_ID["(20)"]
        .expr.rhs.xreplace(paper)
        .xreplace({S["m"]: 1, S["g"]: 1, S["r_e"]: 1, S["q"]: q10})
    )
    assert sm.cancel(lim["E0"].xreplace(ours) - e20) == 0
    slope = tle_model.stride_forms()["slope"].xreplace(ours)
    assert sm.simplify(slope - EQUATION_BY_ID["(19)"].expr.rhs) == 0
    # The c above is cos theta_1 of (11).
    cos_theta_I = tle_model.cos_I
    for symbol, value in reversed(tle_model.geometry()):  # the intermediates substituted
        cos_theta_I = cos_theta_I.xreplace({symbol: value})
    cos_theta_I = cos_theta_I.xreplace(ours)
    theta_1 = EQUATION_BY_ID["(11)"].expr.rhs
    for beta, phi0 in ((0.8, 0.7), (0.95, 0.3), (0.6, 1.2)):
        at = {S["beta"]: sm.Float(beta, 40), S["varphi_0"]: sm.Float(phi0, 40)}
        assert abs((sm.cos(theta_1) - cos_theta_I).xreplace(at).evalf(40)) < 1e-35
    # Rates: the first-order terms carry sin(theta_II), the second-order ones cos(theta_II).
    for name in ("q1", "E1"):
        assert lim[name].xreplace({tle_model.theta_II: 0}) == 0
        assert lim[name] != 0
    for name in ("q2", "E2"):
        assert lim[name].xreplace({tle_model.theta_II: 0}) != 0


@pytest.mark.parametrize("theta_II, rate", [(-0.1, 1), (0.12, 1), (0.0, 2)])
def test_convergence_rate(theta_II, rate):
    """log-log slope of |TLE - ILE| against delta: the derived rate, with the derived
    leading coefficient; the eigenvalue is the ILE's for every delta."""
    beta, phi0 = 0.93, 0.7
    deltas = np.geomspace(1e-4, 3e-3, 6)
    q_ile = float(ile.q_fixed(beta, theta_II, phi0))
    e_ile = float(ile.energy_complement(beta, theta_II, phi0, q_ile, 1.0, 1.0, 1.0))
    q_tle = np.array([float(tle.q_fixed(beta, theta_II, phi0, d)) for d in deltas])
    e_tle = np.array([float(tle.energy_input(beta, theta_II, phi0, d, qf))
                      for d, qf in zip(deltas, q_tle)])  # fmt: skip
    coefficients = dict(zip(tle.ile_limit.outputs, tle.ile_limit(beta, theta_II, phi0)))
    for values, reference, name in ((q_tle, q_ile, "q"), (e_tle, e_ile, "E")):
        error = np.abs(values - reference)
        slope = np.polyfit(np.log(deltas), np.log(error), 1)[0]
        assert slope == pytest.approx(rate, abs=0.02)
        leading = float(coefficients[f"{name}{rate}"])
        assert (values[0] - reference) / deltas[0] ** rate == pytest.approx(leading, rel=1e-3)
        assert float(coefficients[f"{name}0"]) == pytest.approx(reference, rel=1e-13)
    for d in deltas:
        assert float(tle.eigenvalue(beta, theta_II, phi0, d)) == pytest.approx(
            float(ile.eigenvalue(beta, phi0)), rel=1e-15
        )


@pytest.mark.parametrize("delta", [1e-7, 1e-3, 0.3, 1.5])
def test_stride_map_accurate_for_every_delta(delta):
    """The generated fixed point against the h**2 chain evaluated with mpmath (40 digits,
    J by quadrature): the moment series keep double precision where the closed form of
    J cancels (its terms grow like delta**-10)."""
    beta, theta_II, phi0 = 0.9, -0.05, 1.2
    mp.mp.dps = 40
    b, t2, p0, d = (mp.mpf(v) for v in (beta, theta_II, phi0, delta))
    theta_I = -mp.atan((b - mp.cos(p0)) / mp.sin(p0))
    theta_IV = theta_I + p0

    def r(theta):
        s = (theta - t2) / d
        return b + (1 - b) * (3 * s**2 - 2 * s**3)

    j = mp.quad(lambda th: r(th) ** 3 * mp.sin(th), [t2, t2 + d])
    offset = mp.cos(p0) ** 2 / b**2 * (2 * b**3 * (mp.cos(theta_I) - mp.cos(t2)) + 2 * j
                                       + 2 * (mp.cos(t2 + d) - mp.cos(theta_IV)))  # fmt: skip
    q_f = offset / (1 - b**2 * mp.cos(p0) ** 2)
    assert float(tle.q_fixed(beta, theta_II, phi0, delta)) == pytest.approx(float(q_f), rel=1e-13)


# --- backends ---------------------------------------------------------------------------------

ARGUMENTS = {"beta": 0.93, "theta_II": -0.1, "phi0": 0.7, "delta": 0.4, "theta": 0.12,
             "theta_dot": 0.45, "q": 0.21, "fraction": 0.37}  # fmt: skip


def _generated_functions():
    return [name for name, fn in vars(tle).items() if inspect.isfunction(fn)
            and fn.__module__ == tle.__name__ and not name.startswith("_")]  # fmt: skip


@pytest.mark.parametrize("name", _generated_functions())
def test_numpy_and_casadi_agree(name):
    import casadi as ca

    fn = getattr(tle, name)
    names = list(inspect.signature(fn).parameters)
    args = [ARGUMENTS[n] for n in names]
    numpy_out = np.atleast_1d(np.array(fn(*args), dtype=float)).ravel()
    symbols = [ca.SX.sym(n) for n in names]
    outs = fn(*symbols)
    outs = list(outs) if isinstance(outs, tuple) else [outs]
    f = ca.Function("f", symbols, [ca.vertcat(*outs)])
    casadi_out = np.array(f(*args), dtype=float).ravel()
    assert np.all(np.isfinite(numpy_out))
    np.testing.assert_allclose(casadi_out, numpy_out, rtol=1e-12, atol=1e-14)


def test_numpy_broadcasts():
    betas = np.array([0.9, 0.93, 0.95])
    out = tle.fixed_point_conditions(betas, -0.1, 0.7, 0.4)
    for k, beta in enumerate(betas):
        single = tle.fixed_point_conditions(beta, -0.1, 0.7, 0.4)
        np.testing.assert_allclose([o[k] for o in out], single, rtol=1e-15)


# --- the engine pieces ------------------------------------------------------------------------


def test_a_jump_where_the_held_values_agree_is_continuity():
    import sympy as sm

    from derive.engine.hybrid import jump_reset
    from derive.engine.model import Jump
    from derive.models import tle as tle_model

    events = tuple(
        dataclasses.replace(e, reset=Jump()) if e.name.startswith("extension") else e
        for e in tle_model.MODEL.events
    )
    jumping = dataclasses.replace(tle_model.MODEL, events=events)
    for event in events[:2]:
        coords, rates = jump_reset(jumping, event.name)
        assert coords == (tle_model.theta,)
        after = rates[0].xreplace({tle_model.theta: event.at})
        assert sm.simplify(after - tle_model.omega) == 0


def test_continuous_transition_checks_the_held_values():
    import sympy as sm

    from derive.engine.hybrid import continuous_reset
    from derive.models import tle as tle_model

    s = (tle_model.theta - tle_model.theta_II) / tle_model.delta
    short_of_full = tle_model.beta + (sm.Rational(9, 10) - tle_model.beta) * (3 * s**2 - 2 * s**3)
    phase = dataclasses.replace(tle_model.EXTENSION, held={tle_model.r: short_of_full})
    phases = (tle_model.SHORT, phase, tle_model.LONG)
    broken = dataclasses.replace(tle_model.MODEL, phases=phases)
    assert continuous_reset(broken, "extension_start")[1] == (tle_model.omega,)
    with pytest.raises(AssertionError, match="extension_end"):
        continuous_reset(broken, "extension_end")


def test_polynomial_trig_integral_is_sympys():
    import sympy as sm

    from derive.engine.hybrid import integrate_polynomial_trig

    s, a, b = sm.symbols("s a b", real=True)
    for integrand in (s**3 * sm.sin(2 * s + a), (s**2 + b * s) * sm.cos(3 * s) + s, 5 * sm.sin(s)):
        ours = integrate_polynomial_trig(integrand, s, a, b)
        assert sm.simplify(ours - sm.integrate(integrand, (s, a, b))) == 0
    assert integrate_polynomial_trig(sm.sin(s) ** 2, s, a, b) is None
    assert integrate_polynomial_trig(sm.exp(s), s, a, b) is None
