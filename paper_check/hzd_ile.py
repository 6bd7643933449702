"""The ILE as a hybrid zero dynamics: the restricted Poincaré map that :mod:`derive.hzd`
derives for the point-mass biped (``point_mass_biped_switch``) under the ILE's virtual
constraints (``paper_check/ile_hzd_constraints.py``) against the paper's stride map (7),
its fixed point (10) and eigenvalue (19), as printed in :mod:`paper_check.equations`.

The derivation gives the map on ``zeta = sigma^2/2`` just before heelstrike, ``zeta_{k+1} =
delta^2 zeta_k - V(theta_IV)`` (``sigma = I(theta) theta_dot``, the angular momentum about
the stance foot). Just after heelstrike ``zeta_+ = delta^2 zeta_-``, so ``zeta_+`` maps by
``zeta_+ -> delta^2 (zeta_+ - V)``; the paper's state is ``q = omega_I^2`` in the
dimensionless time ``tau = sqrt(g/r_c) t``: ``q = 2 zeta_+ r_c/(g I(theta_I)^2)``. So the
derived map is ``q -> delta^2 q - 2 delta^2 V r_c/(g I(theta_I)^2)``.

Symbolically the parameters are ``theta_I``, ``theta_IV``, ``theta_II``, ``r_c``, ``m``,
``g``, the model's in them by the geometry (5): ``r_s = r_c cos theta_IV/cos theta_I``
(``beta = r_s/r_c``), ``phi0 = theta_IV - theta_I``, the new foot ``d = r_c sin theta_IV -
r_s sin theta_I`` ahead and the switch ``sigma d = r_c sin theta_IV``. Numerically, at
random parameter sets that satisfy the paper's conditions (13), (15)-(17): the file's
constraints as written (``theta_I`` and ``theta_IV`` by ``asin``), ``V`` both in closed form
and by Gauss-Legendre quadrature of ``kappa``, against the printed (7), (10), (19) and the
generated ILE's ``stride_map``, ``q_fixed`` and ``eigenvalue`` to 1e-12; and the runtime's
numbers (:func:`runtime_check`: the point-mass biped's generated impact from the surface,
``delta`` from the angular momenta about the two feet, ``V`` by the runtime's Fejér
quadrature) against the generated ILE to 1e-9. ``vsw hzd`` itself does not run these
constraints: its computed-torque loop cannot make the configuration's jump.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import sympy as sm

from derive.hzd import THETA, reduce, restricted_map
from derive.models.point_mass_biped_switch import MODEL
from generated import ile
from paper_check.equations import EQUATION_BY_ID, PAPER_SYMBOLS
from paper_check.ile_hzd_constraints import CONSTRAINTS

__all__ = ["NUMERIC_TOL", "audit_hzd", "derived_map", "numeric_check", "switch_parameters",
           "symbolic_check"]  # fmt: skip

NUMERIC_TOL = 1e-12
"""Largest relative difference allowed between the derived map and the printed forms."""
RUNTIME_TOL = 1e-9
"""Largest relative difference allowed between the runtime's numbers and the ILE's."""
SAMPLES = 200
SEED = 20240607
_NODES = 40
"""Gauss-Legendre points per piece of the quadrature of kappa (exact to round-off for the
smooth ``m^2 g r^3 sin theta``)."""

_T1, _T4, _T2 = sm.symbols("theta_I theta_IV theta_II", real=True)
_RC, _M, _G = sm.symbols("r_c m g", positive=True)
_Q = sm.Symbol("q", positive=True)


def switch_parameters(beta: Any, phi0: Any, r_c: Any = 1.0) -> dict[str, Any]:
    """The model's parameters that make its step the ILE's: ``l = r_c``, ``l_min = beta
    r_c``, the new foot ``d`` ahead and the switch ``sigma d`` from the geometry (5) with
    theta_I of (11) (numpy or sympy values)."""
    lib = sm if isinstance(beta, sm.Basic) or isinstance(phi0, sm.Basic) else np
    theta_1 = -lib.atan((beta - lib.cos(phi0)) / lib.sin(phi0))
    theta_4 = theta_1 + phi0
    d = r_c * lib.sin(theta_4) - beta * r_c * lib.sin(theta_1)
    return {"l": r_c, "l_min": beta * r_c, "d": d, "sigma": r_c * lib.sin(theta_4) / d}


def derived_map(constraints: Any = CONSTRAINTS) -> tuple[sm.Expr, sm.Expr, dict]:
    """The derived map's slope and offset in ``q`` (in the model's and the constraints'
    symbols) and the reduction's symbols."""
    reduced = reduce(MODEL, constraints)
    delta2, v = restricted_map(reduced)
    if v is None:
        raise ValueError("no closed form of V for the ILE's constraints")
    s = reduced.symbols
    inertia_plus = reduced.inertia[0].xreplace({THETA: reduced.breaks[0]})
    scale = 2 * s["l"] / (s["g"] * inertia_plus**2)
    return delta2, -delta2 * v * scale, s


def _geometry(symbols: dict) -> dict:
    """The model's parameters in theta_I, theta_IV, r_c by (5)."""
    l_min = _RC * sm.cos(_T4) / sm.cos(_T1)
    d = _RC * sm.sin(_T4) - l_min * sm.sin(_T1)
    return {symbols["l"]: _RC, symbols["l_min"]: l_min, symbols["d"]: d,
            symbols["sigma"]: _RC * sm.sin(_T4) / d, symbols["m"]: _M, symbols["g"]: _G,
            symbols["theta_II"]: _T2}  # fmt: skip


def _paper(eq_id: str) -> sm.Expr:
    """The right side of a printed equation, in theta_I, theta_IV, theta_II (and q for
    (7), ``omega_1^2 = q``)."""
    p = PAPER_SYMBOLS
    rhs = EQUATION_BY_ID[eq_id].parsed[0].rhs
    beta = sm.cos(_T4) / sm.cos(_T1)
    return rhs.xreplace({p["omega_1"]: sm.sqrt(_Q), p["beta"]: beta, p["varphi_0"]: _T4 - _T1,
                         p["theta_1"]: _T1, p["theta_II"]: _T2})  # fmt: skip


def symbolic_check() -> dict[str, Any]:
    """The residuals of the derived map's slope and offset against (7), of its slope
    against (19) and of its fixed point against (10), each simplified (zero: the same),
    and the impact's landing on the surface (the phase after it theta_I, the leg r_s)."""
    own = {**CONSTRAINTS.parameters, "theta_I": None, "theta_IV": None}
    at_section = dataclasses.replace(CONSTRAINTS, theta_plus=sm.Symbol("theta_I"),
                                     theta_minus=sm.Symbol("theta_IV"), parameters=own)  # fmt: skip
    slope, offset, symbols = derived_map(at_section)
    swap = {**_geometry(symbols), symbols["theta_I"]: _T1, symbols["theta_IV"]: _T4}
    slope, offset = slope.xreplace(swap), offset.xreplace(swap)
    printed = _paper("(7)")
    paper_slope = sm.diff(printed, _Q)
    paper_offset = printed.xreplace({_Q: 0})
    fixed = offset / (1 - slope)
    geometry = swap
    landing_x = (_RC * sm.sin(_T4) - geometry[symbols["d"]]) / geometry[symbols["l_min"]]
    landing_y = _RC * sm.cos(_T4) / geometry[symbols["l_min"]]
    residuals = {
        "(7) slope: derived - printed": slope - paper_slope,
        "(7) offset: derived - printed": offset - paper_offset,
        "(19): derived slope - printed eigenvalue": slope - _paper("(19)"),
        "(10): derived fixed point - printed": fixed - _paper("(10)"),
        "landing: sin(phase after heelstrike) - sin theta_I": landing_x - sm.sin(_T1),
        "landing: cos(phase after heelstrike) - cos theta_I": landing_y - sm.cos(_T1),
    }
    return {
        "derived slope": slope,
        "derived offset": offset,
        "residuals": {k: sm.simplify(sm.expand_trig(sm.simplify(v))) for k, v in residuals.items()},
    }


def _sample(n: int, seed: int) -> dict[str, np.ndarray]:
    """Parameter sets with (15) beta > cos phi0, (16) phi0 < pi/2, (17) theta_II < phi0/2,
    theta_I < theta_II < theta_IV and (13) q^f > 0."""
    rng = np.random.default_rng(seed)
    out: dict[str, list] = {"beta": [], "phi0": [], "theta_II": [], "r_c": [], "m": [], "g": []}
    while len(out["beta"]) < n:
        phi0 = rng.uniform(0.1, math.pi / 2 - 0.02)
        beta = rng.uniform(math.cos(phi0), 1.0) * 0.995 + 0.005 * math.cos(phi0)
        lo, hi = float(ile.theta_I(beta, phi0)), float(ile.theta_IV(beta, phi0))
        theta_II = rng.uniform(lo, min(hi, phi0 / 2))
        if not (beta > math.cos(phi0) and lo < theta_II and ile.q_fixed(beta, theta_II, phi0) > 0):
            continue
        for k, v in (("beta", beta), ("phi0", phi0), ("theta_II", theta_II),
                     ("r_c", rng.uniform(0.2, 2.0)), ("m", rng.uniform(0.1, 100.0)),
                     ("g", rng.uniform(1.0, 20.0))):  # fmt: skip
            out[k].append(v)
    return {k: np.array(v) for k, v in out.items()}


def _quadrature_v(reduced: Any, values: dict) -> float:
    """``V(theta_IV) = -integral kappa`` by Gauss-Legendre on each piece."""
    nodes, weights = np.polynomial.legendre.leggauss(_NODES)
    total = 0.0
    for lo, hi, kappa in zip(reduced.breaks, reduced.breaks[1:], reduced.kappa):
        a, b = float(lo.xreplace(values)), float(hi.xreplace(values))
        f = sm.lambdify(THETA, kappa.xreplace(values), "numpy")
        t = 0.5 * (b - a) * nodes + 0.5 * (a + b)
        total += 0.5 * (b - a) * float(np.sum(weights * np.broadcast_to(f(t), t.shape)))
    return -total


def _relative(a: float, b: float) -> float:
    return abs(a - b) / max(1.0, abs(b))


def numeric_check(n: int = SAMPLES, seed: int = SEED) -> dict[str, Any]:
    """The largest relative differences over ``n`` parameter sets (see the module
    docstring): the derived map in closed form and by quadrature against (7), (10), (19)
    as printed and the generated ILE."""
    reduced = reduce(MODEL, CONSTRAINTS)
    slope, offset, s = derived_map()
    args = [s[k] for k in ("m", "g", "l", "d", "l_min", "sigma", "theta_II")]
    f = sm.lambdify([*args, _Q], slope * _Q + offset, "math")
    f_slope = sm.lambdify(args, slope, "math")
    p = PAPER_SYMBOLS
    paper_args = [p["beta"], p["varphi_0"], p["theta_II"], p["theta_1"], p["omega_1"]]
    printed = {e: sm.lambdify(paper_args, EQUATION_BY_ID[e].parsed[0].rhs, "math")
               for e in ("(7)", "(10)", "(19)")}  # fmt: skip
    worst = dict.fromkeys(["(7) closed form", "(7) quadrature", "(10)", "(19)",
                           "generated stride_map", "generated q_fixed", "generated eigenvalue"],
                          0.0)  # fmt: skip
    sets = _sample(n, seed)
    rng = np.random.default_rng(seed + 1)
    for k in range(n):
        beta, phi0, t2, rc = (float(sets[v][k]) for v in ("beta", "phi0", "theta_II", "r_c"))
        sw = switch_parameters(beta, phi0, rc)
        vals = [float(sets["m"][k]), float(sets["g"][k]), sw["l"], sw["d"], sw["l_min"],
                sw["sigma"], t2]  # fmt: skip
        q = rng.uniform(0.05, 3.0)
        t1 = float(ile.theta_I(beta, phi0))
        paper = printed["(7)"](beta, phi0, t2, t1, math.sqrt(q))
        got = f(*vals, q)
        lam = f_slope(*vals)
        qf = (f(*vals, 0.0)) / (1 - lam)
        values = dict(zip(args, vals))
        d2 = float(reduced.delta.xreplace(values)) ** 2
        inertia = float(reduced.inertia[0].xreplace({**values, THETA: 0}))
        by_quad = d2 * q - d2 * _quadrature_v(reduced, values) * 2 * sw["l"] / (
            vals[1] * inertia**2
        )
        for key, a, b in (
            ("(7) closed form", got, paper),
            ("(7) quadrature", by_quad, paper),
            ("(10)", qf, printed["(10)"](beta, phi0, t2, t1, 0.0)),
            ("(19)", lam, printed["(19)"](beta, phi0, t2, t1, 0.0)),
            ("generated stride_map", got, float(ile.stride_map(beta, t2, phi0, q))),
            ("generated q_fixed", qf, float(ile.q_fixed(beta, t2, phi0))),
            ("generated eigenvalue", lam, float(ile.eigenvalue(beta, phi0))),
        ):
            worst[key] = max(worst[key], float(_relative(a, b)))
    return {"parameter sets": n, "seed": seed, "largest relative difference": worst}


def _runtime_step(walker: Any, kappa: Any, sets: dict, k: int) -> dict[str, float]:
    """One parameter set through the runtime: the model's generated impact from the
    surface at theta_IV, the phase and leg after it, delta from the angular momenta about
    the new and the old foot, and V by the runtime's quadrature by Fejér's first rule."""
    from vsw.synthesis.hzd.zero import chebyshev_integral

    beta, phi0, t2, rc, m, g = (float(sets[v][k]) for v in
                                ("beta", "phi0", "theta_II", "r_c", "m", "g"))  # fmt: skip
    sw = switch_parameters(beta, phi0, rc)
    params = walker.parameters({"m": m, "g": g, **{n: float(v) for n, v in sw.items()}})
    t1, t4 = float(ile.theta_I(beta, phi0)), float(ile.theta_IV(beta, phi0))
    before = np.array([rc * math.sin(t4), rc * math.cos(t4), rc * math.cos(t4),
                       -rc * math.sin(t4)])  # theta_dot = 1  # fmt: skip
    x, y, vx, vy = walker.reset(walker.step_event["name"], params, before)
    delta = (y * vx - x * vy) / rc**2
    values = (*params, t2)
    v = 0.0
    for (lo, hi), f in zip(((t1, t2), (t2, t4)), kappa):
        v -= float(chebyshev_integral(lambda t, f=f: f(*values, t) + 0 * t, lo, hi)(hi))
    slope = delta**2
    offset = -slope * v * 2 * rc / (g * (m * (beta * rc) ** 2) ** 2)
    q = 0.5 + k % 5 * 0.4
    return {
        "phase after heelstrike": _relative(math.atan2(x, y), t1),
        "leg after heelstrike": _relative(math.hypot(x, y), beta * rc),
        "stride_map": _relative(slope * q + offset, float(ile.stride_map(beta, t2, phi0, q))),
        "q_fixed": _relative(offset / (1 - slope), float(ile.q_fixed(beta, t2, phi0))),
        "eigenvalue": _relative(slope, float(ile.eigenvalue(beta, phi0))),
    }


def runtime_check(n: int = 50, seed: int = SEED + 2) -> dict[str, Any]:
    """The runtime's numbers against the generated ILE's closed forms over ``n`` parameter
    sets: the point-mass biped's generated impact (``vsw.models``) and the runtime's
    quadrature of the derived ``kappa`` (``vsw.synthesis.hzd.zero.chebyshev_integral``)."""
    from vsw.models import load

    walker = load("point-mass-biped-switch")
    reduced = reduce(MODEL, CONSTRAINTS)
    s = reduced.symbols
    args = [s[k] for k in ("m", "g", "l", "d", "l_min", "sigma", "theta_II")] + [THETA]
    kappa = [sm.lambdify(args, k, "numpy") for k in reduced.kappa]
    sets = _sample(n, seed)
    worst: dict[str, float] = {}
    for k in range(n):
        for key, err in _runtime_step(walker, kappa, sets, k).items():
            worst[f"runtime {key}"] = max(worst.get(f"runtime {key}", 0.0), float(err))
    return {"parameter sets": n, "seed": seed, "largest relative difference": worst}


def audit_hzd() -> list:
    """The section's entries: (7), (10) and (19) as the HZD's restricted map."""
    from paper_check.audit import Entry

    sym = symbolic_check()
    res = sym["residuals"]
    num = numeric_check()
    worst = num["largest relative difference"]
    landing = all(v == 0 for k, v in res.items() if k.startswith("landing"))
    run = runtime_check()
    at_runtime = run["largest relative difference"]
    plan = (
        ("hzd-(7)", "(7)", "the stride map is the HZD's restricted map",
         ["(7) slope: derived - printed", "(7) offset: derived - printed"],
         ["(7) closed form", "(7) quadrature", "generated stride_map"],
         ["runtime stride_map", "runtime phase after heelstrike",
          "runtime leg after heelstrike"]),
        ("hzd-(10)", "(10)", "its fixed point", ["(10): derived fixed point - printed"],
         ["(10)", "generated q_fixed"], ["runtime q_fixed"]),
        ("hzd-(19)", "(19)", "its eigenvalue delta^2",
         ["(19): derived slope - printed eigenvalue"], ["(19)", "generated eigenvalue"],
         ["runtime eigenvalue"]),
    )  # fmt: skip
    entries = []
    for entry_id, eq, title, keys, nums, runs in plan:
        zero = all(res[k] == 0 for k in keys) and landing
        close = all(worst[k] <= NUMERIC_TOL for k in nums)
        close &= all(at_runtime[k] <= RUNTIME_TOL for k in runs)
        evidence = {
            "symbolic": {
                **{k: str(res[k]) for k in keys},
                "impact lands on the surface": landing,
            },
            "numeric": {
                "parameter sets": num["parameter sets"],
                "seed": num["seed"],
                "tolerance": NUMERIC_TOL,
                **{k: worst[k] for k in nums},
            },
            "runtime": {
                "parameter sets": run["parameter sets"],
                "seed": run["seed"],
                "tolerance": RUNTIME_TOL,
                **{k: at_runtime[k] for k in runs},
            },
        }
        entries.append(Entry(
            id=entry_id, title=f"{eq} as the hybrid zero dynamics: {title}",
            verdict="equivalent" if zero and close else "wrong", evidence=evidence,
            note="derive.hzd's restricted map of the point-mass biped under the ILE's "
            "virtual constraints (paper_check/ile_hzd_constraints.py), in q = omega_I^2; "
            "equal after simplification under the geometry (5): beta = cos theta_IV/cos "
            "theta_I, phi0 = theta_IV - theta_I",
            paper=EQUATION_BY_ID[eq].latex,
            derived=rf"\delta^2 = {sm.latex(sm.simplify(sym['derived slope']))}"
            if eq == "(19)"
            else "",
        ))  # fmt: skip
    return entries
