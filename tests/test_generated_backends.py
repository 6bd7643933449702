"""Generated numpy, CasADi and compiled C agree; the runtime imports no sympy."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import generated.ile as ile
from tests.conftest import random_valid_parameters, random_walking_parameters

ROOT = Path(__file__).resolve().parent.parent
REL_TOL = 1e-12


def rel_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))


def casadi_eval(fn, *args):
    """Evaluate a generated function on SX symbols, then numerically through ca.Function."""
    symbols = [ca.SX.sym(f"a{i}") for i in range(len(args))]
    out = fn(*symbols)
    outs = list(out) if isinstance(out, tuple) else [out]
    f = ca.Function("f", symbols, [ca.vertcat(*outs)])
    return np.array(f(*[float(a) for a in args])).ravel()


def _params(p):
    return p["beta"], p["theta_II"], p["phi0"]


SCALAR_CASES = [
    ("q_fixed", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("eigenvalue", lambda p: (p["beta"], p["phi0"])),
    ("stride_map", lambda p: (p["beta"], p["theta_II"], p["phi0"], 0.37)),
    ("q_apex_min", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("q_liftoff_max", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("contact_margin", lambda p: (p["beta"], p["theta_II"], p["phi0"], 0.4)),
    ("phase_durations", lambda p: (*_params(p), ile.q_fixed(*_params(p)))),
    ("condition_margins", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("fixed_point_conditions", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("condition_pieces", lambda p: (p["beta"], p["theta_II"], p["phi0"])),
    ("energy_complement", lambda p: (p["beta"], p["theta_II"], p["phi0"], 0.4, 0.78, 9.81, 0.25)),
]  # fmt: skip


@pytest.mark.parametrize("name,make_args", SCALAR_CASES, ids=[c[0] for c in SCALAR_CASES])
def test_numpy_and_casadi_agree(name, make_args):
    draws = random_walking_parameters(25, seed=7)
    fn = getattr(ile, name)
    for i in range(25):
        p = {k: float(v[i]) for k, v in draws.items()}
        args = make_args(p)
        numpy_out = np.atleast_1d(np.array(fn(*args), dtype=float)).ravel()
        # Relative, with an absolute floor of 1e-14 for values that cancel to about zero.
        np.testing.assert_allclose(casadi_eval(fn, *args), numpy_out, rtol=REL_TOL, atol=1e-14)


def test_numpy_broadcasts_over_parameter_arrays():
    draws = random_valid_parameters(1000, seed=3)
    beta, theta_II, phi0 = draws["beta"], draws["theta_II"], draws["phi0"]
    vector = ile.q_fixed(beta, theta_II, phi0)
    assert vector.shape == (1000,)
    loop = np.array([ile.q_fixed(b, t, p) for b, t, p in zip(beta[:50], theta_II[:50], phi0[:50])])
    np.testing.assert_allclose(vector[:50], loop, rtol=1e-14)
    grid = ile.q_fixed(beta[:7, None], theta_II[None, :5], 0.8)
    assert grid.shape == (7, 5)


@pytest.fixture(scope="module")
def c_library(tmp_path_factory):
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler")
    from vsw.dynamics.ccode import CLibrary

    return CLibrary.build(tmp_path_factory.mktemp("c"))


def test_compiled_c_agrees_with_numpy(c_library):
    draws = random_walking_parameters(200, seed=11)
    b, t, p = draws["beta"], draws["theta_II"], draws["phi0"]
    qf = ile.q_fixed(b, t, p)
    durations = ile.phase_durations(b, t, p, qf)
    length = ile.step_length(b, p)
    period = durations[0] + durations[1]
    margins = np.array(np.broadcast_arrays(*ile.condition_margins(b, t, p)))
    for i in range(len(b)):
        args = (b[i], t[i], p[i])
        assert rel_err(c_library.call("q_fixed", *args), qf[i]) <= REL_TOL
        assert (
            rel_err(c_library.call("eigenvalue", b[i], p[i]), ile.eigenvalue(b[i], p[i])) <= REL_TOL
        )
        assert (
            rel_err(c_library.call("stride_map", *args, 0.3), ile.stride_map(*args, 0.3)) <= REL_TOL
        )
        metrics = c_library.call("step_metrics", *args)
        expected = [length[i], period[i], length[i] / period[i], ile.contact_margin(*args, qf[i])]
        assert rel_err(metrics, expected) <= REL_TOL
        assert rel_err(c_library.call("condition_margins", *args), margins[:, i]) <= REL_TOL


def test_c_source_is_self_contained_c99(tmp_path):
    if shutil.which("cc") is None:
        pytest.skip("no C compiler")
    obj = tmp_path / "ile.o"
    done = subprocess.run(
        ["cc", "-std=c99", "-pedantic", "-Wall", "-Werror", "-Wno-unused-parameter", "-c",
         str(ROOT / "generated" / "ile" / "c" / "ile.c"), "-o", str(obj)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr


def test_runtime_never_imports_sympy():
    code = (
        "import sys, importlib, pkgutil\n"
        "sys.modules['sympy'] = None  # any import of sympy now raises ImportError\n"
        "import vsw, generated.ile as ile\n"
        "for m in pkgutil.walk_packages(vsw.__path__, 'vsw.'):\n"
        "    importlib.import_module(m.name)\n"
        "print(ile.q_fixed(0.8, 0.0, 0.7853981633974483))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert abs(float(done.stdout) - 0.465196423021) < 1e-9


@pytest.mark.parametrize("ratio", [1.0, 1e-3, 1e-6, 1e-9, 1e-12, 1e-15])
def test_carlson_rf_matches_scipy_on_both_backends(ratio):
    from scipy.special import elliprf

    from generated._backend import NUMPY, _casadi_ops

    rng = np.random.default_rng(int(-np.log10(ratio)))
    n = 2000
    x = rng.uniform(0, 1, n) * ratio
    y = rng.uniform(0, 1, n) * np.where(rng.uniform(size=n) < 0.5, ratio, 1.0)
    z = rng.uniform(0.1, 1, n)
    reference = elliprf(x, y, z)
    assert rel_err(NUMPY.carlson_rf(x, y, z), reference) <= 4e-15
    sx, sy, sz = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("z")
    rf = ca.Function("rf", [sx, sy, sz], [_casadi_ops().carlson_rf(sx, sy, sz)]).map(n)
    assert rel_err(np.array(rf(x, y, z)).ravel(), reference) <= 4e-15


@pytest.mark.parametrize("scale", [1e-8, 1.0, np.pi, 1e4])
def test_cos_sin_from_half_angle_tangent_matches_libm(scale):
    """be.cos_sin (one tan of the half angle) against np.cos/np.sin, values and CasADi AD."""
    from generated._backend import NUMPY, _casadi_ops

    rng = np.random.default_rng(7)
    x = rng.uniform(-scale, scale, 5000)
    x[:3] = (np.pi / 2, -np.pi / 2, np.pi) if scale >= np.pi else (0.0, scale / 3, -scale)
    cos, sin = NUMPY.cos_sin(x)
    # Absolute error of a few ulp of 1, as for an input perturbed by about one ulp.
    tol = 8 * np.finfo(float).eps * max(1.0, scale)
    assert np.max(np.abs(cos - np.cos(x))) <= tol
    assert np.max(np.abs(sin - np.sin(x))) <= tol
    near_zero = np.abs(x) < 1e-3
    if near_zero.any():  # sin keeps its relative accuracy at small angles
        assert rel_err(sin[near_zero], np.sin(x[near_zero])) <= 4e-16
    scalar = NUMPY.cos_sin(float(x[5]))
    assert scalar == (cos[5], sin[5])
    sx = ca.SX.sym("x")
    c_sx, s_sx = _casadi_ops().cos_sin(sx)
    f = ca.Function("f", [sx], [c_sx, s_sx, ca.jacobian(c_sx, sx), ca.jacobian(s_sx, sx)]).map(
        x.size
    )
    c_ca, s_ca, dc, ds = (np.array(v).ravel() for v in f(x))
    assert np.max(np.abs(c_ca - np.cos(x))) <= tol
    assert np.max(np.abs(s_ca - np.sin(x))) <= tol
    # The AD chain passes through d tan(x/2)/dx, large near x = +-pi: a little looser there.
    assert np.max(np.abs(dc + np.sin(x))) <= 64 * tol
    assert np.max(np.abs(ds - np.cos(x))) <= 64 * tol


@pytest.mark.parametrize("draw", [random_walking_parameters, random_valid_parameters])
def test_fused_existence_matches_the_explicit_forms(draw):
    """fixed_point_conditions (staged: q^f = f(0)/(1 - lambda), apex margin as min omega**2 / k,
    indicator form of the apex-closest cosine) against q_fixed, eigenvalue and
    condition_margins, generated from the fully substituted expressions."""
    p = draw(20000, seed=11)
    args = _params(p)
    with np.errstate(all="ignore"):
        fused = ile.fixed_point_conditions(*args)
        explicit = (ile.q_fixed(*args), ile.eigenvalue(args[0], args[2]))
        explicit += ile.condition_margins(*args)
    assert len(fused) == len(explicit) == 2 + len(ile.CONDITIONS)
    for k, (a, b) in enumerate(zip(fused, explicit)):
        assert np.array_equal(np.isnan(a), np.isnan(b)), k
        ok = ~np.isnan(b)
        # Relative to max(|value|, 1): margins cross zero, where relative error means nothing.
        scale = np.maximum(np.abs(b[ok]), 1.0)
        assert np.max(np.abs(a[ok] - b[ok]) / scale) <= 1e-9, k
        assert np.array_equal(a[ok] > 0, b[ok] > 0) or np.all(
            np.abs(b[ok][(a[ok] > 0) != (b[ok] > 0)]) < 1e-12
        ), k


@pytest.mark.slow
def test_fused_existence_against_40_digit_evaluation_of_the_derivation(ile_derivation):
    """fixed_point_conditions in doubles against the derived expressions evaluated with 40
    digits (mpmath), at random sets and at ill-conditioned corners of the domain."""
    import sympy as sm

    from derive.models import ile as model

    d = ile_derivation
    exprs = [d.quantities["q_fixed"].expr, d.quantities["eigenvalue"].expr]
    exprs += [c.margin for c in d.conditions]
    p = random_valid_parameters(12, seed=5)
    points = list(zip(p["beta"], p["theta_II"], p["phi0"]))
    # Short steps (phi0 -> 0, beta -> 1) and short stance legs (beta -> 0).
    points += [(0.9985089293722981, 0.6421, 0.0016637), (0.0024758922927859, 0.0027946, 1.54907)]
    worst = 0.0
    for b, t, f in points:
        b, t, f = float(b), float(t), float(f)
        with np.errstate(all="ignore"):
            fused = ile.fixed_point_conditions(np.array([b]), np.array([t]), np.array([f]))
        subs = {model.beta: sm.Float(b, 60), model.theta_II: sm.Float(t, 60)}
        subs[model.phi0] = sm.Float(f, 60)
        for value, expr in zip(fused, exprs):
            exact = float(expr.evalf(40, subs=subs))
            worst = max(worst, abs(float(value[0]) - exact) / max(abs(exact), 1.0))
    # The squared foot distance is derived as (1 - beta)**2 + 2 beta sin**2/(1 + cos), not
    # 1 + beta**2 - 2 beta cos(phi0), which cancels to 2e-6 at the short-step corner and
    # cost 1e-10 there.
    assert worst <= 1e-12


def test_condition_pieces_equal_the_exact_margins_region_by_region():
    """The smooth pieces the design NLP imposes (derive.models.ile.condition_pieces) give
    the exact apex margin (14) in each region of the signs of theta_I and theta_II, and the
    stance-contact margin as their minimum wherever the foot stays down; checked against
    condition_margins, itself tested against brute force over the step."""
    p = random_walking_parameters(20000, seed=3)
    b, t, f = _params(p)
    apex_I_II, apex_III_IV, n_I, n_II, n_IV = ile.condition_pieces(b, t, f)
    margins = dict(zip([c[0] for c in ile.CONDITIONS], ile.condition_margins(b, t, f)))
    theta_I = ile.theta_I(b, f)
    regions = {
        "theta_II <= 0": (t <= 0, apex_III_IV),
        "theta_I <= 0 <= theta_II": ((t >= 0) & (theta_I <= 0), apex_I_II),
        "theta_I >= 0": (theta_I >= 0, ile.q_fixed(b, t, f)),
    }
    for name, (inside, piece) in regions.items():
        assert inside.sum() > 1000, name
        scale = np.maximum(np.abs(margins["apex"][inside]), 1.0)
        assert np.max(np.abs(margins["apex"][inside] - piece[inside]) / scale) <= 1e-12, name
    contact = np.minimum(np.minimum(n_I, n_II), n_IV)
    assert np.max(np.abs(margins["stance_contact"] - contact)) <= 1e-12
    # The normal forces are N = cos(theta) (cos(theta) - rho omega**2) at instants I, II, IV.
    q_f = ile.q_fixed(b, t, f)
    w2_II = ile.omega_II_squared(b, t, f, q_f)
    w2_IV = ile.omega_IV_squared(b, t, f, q_f)
    # In the region theta_I <= 0 <= theta_II, phase III-IV's own apex margin, omega_III**2 /
    # beta**4 = omega_II**2, is never the smaller one: the piece of phase I-II decides.
    inside = (t >= 0) & (theta_I <= 0)
    assert np.all(apex_I_II[inside] <= w2_II[inside] + 1e-12)
    np.testing.assert_allclose(n_I, ile.normal_force(theta_I, np.sqrt(q_f), b), atol=1e-12)
    np.testing.assert_allclose(n_II, ile.normal_force(t, np.sqrt(w2_II), b), atol=1e-12)
    np.testing.assert_allclose(
        n_IV, ile.normal_force(ile.theta_IV(b, f), np.sqrt(w2_IV), 1.0), atol=1e-12
    )


# Short steps: phi0 -> 0 with beta -> 1, where cos phi0 rounds to 1 (phi0 < 1.05e-8) and
# differences with 1 (1 - lambda = 1 - beta**2 cos**2 phi0, 1 - cos**2 phi0, the foot
# distance) lose their phi0 part unless derived without the cancellation.
CORNER = [
    (1 - gap, theta, phi)
    for phi in (1e-8, 3e-8, 1e-7, 1e-6, 1e-5, 1e-4)
    for gap in (1e-6, 1e-7, 1e-8, 1e-9, 1e-12)
    for theta in (0.0, -0.3)
]
CORNER_EXTRA = {"q": 0.4, "q_next": 0.4, "m": 0.78, "g": 9.81, "r_e": 0.25}
CORNER_TOL = 8.0
"""Allowed error, in units of eps (1 + kappa): kappa, the componentwise relative condition
number, is what rounding the inputs alone costs. Before 1 - lambda was derived as
(1 - beta)(1 + beta) + beta**2 sin**2 phi0, q^f reached 4500 here."""


@pytest.fixture(scope="module")
def corner_reference(ile_derivation):
    """{name: (args per point, exact values, condition numbers)} from 50-digit evaluation of
    the derived expressions as the derivation states them (not the forms the generator
    evaluates), with kappa = sum |x_i df/dx_i| / |f| from their symbolic derivatives."""
    import mpmath as mp
    import sympy as sm

    from derive.models import ile as model

    d = ile_derivation
    facts = d.facts
    paper = model.eliminate_contact_angles
    P = (model.beta, model.theta_II, model.phi0)
    dims = (model.m, model.g, model.r_e)
    derived = {
        "q_fixed": (P, paper(facts["stride.q_fixed"])),
        "step_length": ((model.beta, model.phi0), sm.sqrt(facts["heelstrike.step_length_squared"])),
        "energy_dissipated": ((*P, model.q, *dims), paper(facts["energy.dissipated"])),
        "energy_dissipated_post": (
            (model.beta, model.phi0, model.q_next, *dims),
            facts["energy.dissipated_post"],
        ),
        "energy_change": ((*P, model.q, *dims), paper(facts["energy.change"])),
    }
    reference = {}
    with mp.workdps(50):
        for name, (args, expr) in derived.items():
            value = sm.lambdify(args, expr, "mpmath")
            grads = [sm.lambdify(args, sm.diff(expr, a), "mpmath") for a in args]
            rows, exact, kappa = [], [], []
            for beta, theta_II, phi0 in CORNER:
                point = {"beta": beta, "theta_II": theta_II, "phi0": phi0, **CORNER_EXTRA}
                x = [point[a.name] for a in args]
                xm = [mp.mpf(v) for v in x]
                f = value(*xm)
                rows.append(x)
                exact.append(float(f))
                kappa.append(float(sum(abs(xi * g(*xm)) for xi, g in zip(xm, grads)) / abs(f)))
            reference[name] = (np.array(rows), np.array(exact), np.array(kappa))
    return reference


def _corner_excess(got, exact, kappa):
    """Error in units of eps (1 + kappa)."""
    got = np.asarray(got, dtype=float).ravel()
    return np.max(np.abs(got - exact) / np.abs(exact) / (np.finfo(float).eps * (1 + kappa)))


CORNER_QUANTITIES = [
    "q_fixed", "step_length", "energy_dissipated", "energy_dissipated_post", "energy_change"
]  # fmt: skip


@pytest.mark.parametrize("name", CORNER_QUANTITIES)
def test_short_step_corner_numpy_and_casadi_within_the_condition_number(corner_reference, name):
    rows, exact, kappa = corner_reference[name]
    fn = getattr(ile, name)
    assert _corner_excess(fn(*rows.T), exact, kappa) <= CORNER_TOL
    symbols = [ca.SX.sym(f"a{i}") for i in range(rows.shape[1])]
    batch = ca.Function("f", symbols, [fn(*symbols)]).map(len(rows))
    assert _corner_excess(np.array(batch(*rows.T)), exact, kappa) <= CORNER_TOL


def test_short_step_corner_fused_and_batch_kernel_q_fixed(corner_reference):
    from vsw.models.ile import kernels

    rows, exact, kappa = corner_reference["q_fixed"]
    assert _corner_excess(ile.fixed_point_conditions(*rows.T)[0], exact, kappa) <= CORNER_TOL
    if kernels.library() is None:
        pytest.skip(kernels.build_error or "kernels disabled")
    q_f = kernels.fixed_point_conditions(*rows.T, threads=1)[0]
    assert _corner_excess(q_f, exact, kappa) <= CORNER_TOL


def test_short_step_corner_compiled_c(corner_reference, c_library):
    rows, exact, kappa = corner_reference["q_fixed"]
    got = [c_library.call("q_fixed", *row)[0] for row in rows]
    assert _corner_excess(got, exact, kappa) <= CORNER_TOL
    rows, exact, kappa = corner_reference["step_length"]
    # step_metrics returns (length, period, speed, contact margin); the length needs no q.
    got = [c_library.call("step_metrics", row[0], 0.0, row[1])[0] for row in rows]
    assert _corner_excess(got, exact, kappa) <= CORNER_TOL
