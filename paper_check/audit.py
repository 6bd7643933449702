"""The equation and claim audit of the paper: evidence, verdicts, and the expected table.

Verdicts are computed from the evidence by explicit rules (:func:`equation_verdict`,
and one rule per claim), never typed in; :data:`EXPECTED_PATH` records the verdicts the
tests expect, and :func:`verdict_changes` lists every difference (the CLI exits non-zero
on any).
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sm

from derive.models import ile as model
from generated import ile
from paper_check import compare
from paper_check.equations import EQUATION_BY_ID, EQUATIONS
from paper_check.figures import curves, plain, walks
from paper_check.simulation import converged, energy_at, run, step_events
from paper_check.walking import FIG_BETA, FIG_PHI0, FIG_THETA_II, failing_reason, walk_mask

__all__ = [
    "EXPECTED_PATH",
    "VERDICTS",
    "Audit",
    "Entry",
    "equation_verdict",
    "expected_verdicts",
    "run_audit",
    "verdict_changes",
]

VERDICTS: dict[str, str] = {
    "identical": "same expression after canonicalisation (expand / cancel over one denominator)",
    "equivalent": "equal after simplification under stated assumptions (named in the entry)",
    "equivalent-at-fixed-point": "holds only on the limit cycle (the entry says why)",
    "conservative": "a condition stricter than the exact one (the exact one is given)",
    "incomplete": "right as far as it goes, but something needed is missing (named)",
    "notation": "the same physics under an inconsistent symbol or definition (named)",
    "wrong": "does not follow (the corrected form and a counterexample are given)",
}
"""The fixed verdict vocabulary with its meaning."""

EXPECTED_PATH = Path(__file__).with_name("expected_verdicts.json")
NUMERIC_TOL = 1e-9
SEED = 20240601
DENSE_SAMPLES = 100_000
SIMS_PER_CATEGORY = 40
SIM_STEPS = 3


@dataclass
class Entry:
    """One audited equation or claim.

    Attributes
    ----------
    id : str
    title : str
        The equation's role or the claim as the paper states it.
    verdict : str
        One of :data:`VERDICTS`.
    evidence : dict
        Tiers ``symbolic``, ``numeric``, ``simulation`` (each present where used).
    note : str
    paper : str
        Printed LaTeX (equations) or the quoted claim.
    derived : str
        Derived form (LaTeX) or the exact statement.
    counterexamples : list of dict
        Parameter sets (degrees for angles) that refute the paper's form, if any.
    """

    id: str
    title: str
    verdict: str
    evidence: dict
    note: str
    paper: str = ""
    derived: str = ""
    counterexamples: list = field(default_factory=list)

    def as_json(self) -> dict[str, Any]:
        """JSON-ready dict with the contract keys first."""
        return {
            "id": self.id,
            "verdict": self.verdict,
            "evidence": _jsonable(self.evidence),
            "note": self.note,
            "title": self.title,
            "paper": self.paper,
            "derived": self.derived,
            "counterexamples": _jsonable(self.counterexamples),
        }


@dataclass
class Audit:
    """The whole audit: equations, claims and the data behind the figures."""

    equations: list[Entry]
    claims: list[Entry]
    figure_data: dict[str, Any]
    settings: dict[str, Any]
    hzd: list[Entry] = field(default_factory=list)
    """(7), (10) and (19) as the restricted map of a hybrid zero dynamics
    (:mod:`paper_check.hzd_ile`)."""

    def verdicts(self) -> dict[str, dict[str, str]]:
        """``{'equations': {id: verdict}, 'claims': {id: verdict}, 'hzd': {id: verdict}}``."""
        return {
            "equations": {e.id: e.verdict for e in self.equations},
            "claims": {c.id: c.verdict for c in self.claims},
            "hzd": {h.id: h.verdict for h in self.hzd},
        }


def _round(x: float) -> float | None:
    """Four significant digits (stable bytes across BLAS / libm differences)."""
    if x is None or not math.isfinite(float(x)):
        return None
    return float(f"{float(x):.4g}")


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return _round(float(value))
    return value


def expected_verdicts(path: Path = EXPECTED_PATH) -> dict[str, dict[str, str]]:
    """The verdict table the tests record (``paper_check/expected_verdicts.json``)."""
    return json.loads(Path(path).read_text())


def verdict_changes(
    found: dict[str, dict[str, str]], expected: dict[str, dict[str, str]]
) -> list[str]:
    """Human-readable differences between found and expected verdicts (empty if none)."""
    changes = []
    for part in ("equations", "claims", "hzd"):
        if part not in found:  # a table of the equations and claims alone
            continue
        got_part, want_part = found[part], expected.get(part, {})
        keys = sorted(set(got_part) | set(want_part))
        for key in keys:
            got, want = got_part.get(key), want_part.get(key)
            if got != want:
                changes.append(f"{part} {key}: expected {want!r}, found {got!r}")
    return changes


# --------------------------------------------------------------------------- equations


def equation_verdict(c: compare.Comparison, walking_violations: dict[str, int]) -> str:
    """Verdict of one equation from its evidence.

    Parameters
    ----------
    c : Comparison
        Symbolic and numeric evidence.
    walking_violations : dict of str to int
        For each printed condition, the number of simulated sets that violate it and still
        walk (from the existence claim).

    Returns
    -------
    str
        A verdict of :data:`VERDICTS`.
    """
    numeric_ok = c.numeric_max_rel_error <= NUMERIC_TOL
    r = c.restricted
    if c.id == "(18)":
        at_fixed = r.get("residual against (21) vanishes at q = q^f", False)
        if c.symbolic_zero and numeric_ok and at_fixed:
            return "equivalent-at-fixed-point"
        return "wrong"
    if c.id == "(17)":
        stricter = r.get("min over samples of theta_IV - phi0/2 (rad), > 0: (17) is stricter", 0)
        return "conservative" if stricter > 0 else "wrong"
    if c.id == "(14)":
        missing = sum(
            v for k, v in r.items() if k.startswith(("samples satisfying", "random")) and v > 0
        )
        if c.symbolic_zero and numeric_ok:
            return "incomplete" if missing else "identical"
        return "wrong"
    if not (c.symbolic_zero and numeric_ok):
        return "wrong"
    if walking_violations.get(c.id, 0) > 0:
        return "conservative"
    if c.assumptions.startswith("0 < beta < 1"):
        return "equivalent"
    return "identical"


def _equation_notes() -> dict[str, str]:
    return {
        "(1)": "Euler-Lagrange equation of a point mass on a massless leg of length r_s.",
        "(2)": "Dimensionless time tau = sqrt(g/r_e) t with r_s = beta r_e.",
        "(3)": "Angular momentum r x m v about the stance foot before (r_s) and after (r_e).",
        "(4)": "Dimensionless swing phase with the extended leg.",
        "(5)": "Swing-foot height zero with the extended stance leg at theta_IV; legs swap.",
        "(6)": "Angular momentum about the swing-foot contact point across the impact.",
        "(7)": "Energy integrals of both phases chained with (3) and (6).",
        "(8)": "Definition of the state; the derivation's map is in q = omega_I^2.",
        "(9)": "(7) in q; linear, slope beta^2 cos^2 phi0.",
        "(10)": "Unique root of f(q) = q (beta cos phi0 < 1).",
        "(11)": "Solved from the guard of (5); |theta_I| < pi/2 (hip above both feet).",
        "(12)": "Same condition as the derivation's q_positive margin.",
        "(13)": "(12) divided by a positive factor: the same set, given 0 < beta < 1 and "
        "cos theta_1 > 0, beta cos phi0 < 1.",
        "(14)": "Each branch is exact when theta_1 < 0 (15) and the stance leg reaches "
        "theta_II. Missing: theta_II > theta_1 (otherwise the leg never extends, and the "
        "printed conditions still pass) and the stance foot staying on the ground (normal "
        "force >= 0 gives an upper bound q <= q_liftoff_max). With theta_1 > 0 the printed "
        "first branch is a bound the walker need not meet (there is no apex to pass).",
        "(15)": "beta > cos phi0 is exactly theta_1 < 0, but it is a framing choice, not "
        "needed for a gait: simulated sets with theta_1 > 0 walk (counterexamples in the "
        "existence claims). Exact replacement: none needed beyond theta_1 < theta_II.",
        "(16)": "cos phi0 > 0 keeps omega after heelstrike positive (eq. 6).",
        "(17)": "Exact: theta_II < theta_IV = theta_1 + phi0. Since beta cos theta_1 = "
        "cos theta_IV with beta < 1, theta_IV > |theta_1|, so theta_IV > phi0/2 always: "
        "phi0/2 (where equal legs would touch down) is stricter than needed.",
        "(18)": "Exact with q = q(n+1), the state just after the impact: E_r = (1/2) m g r_e "
        "beta^2 tan^2(phi0) q(n+1). With the paper's q = q(n) it differs from (21) except at "
        "q = q^f, where q(n+1) = q(n).",
        "(19)": "The map is linear, so the eigenvalue is its slope everywhere.",
        "(20)": "Energy just after minus just before the extension (instants III, II).",
        "(21)": "Energy just before minus just after heelstrike (instants IV, I of n+1).",
        "(22)": "Definition.",
        "(23)": "(20) - (21); E_Delta = -(1/2) m g r_e beta^2 (1 - lambda)(q - q^f).",
    }


SHORT_NOTES: dict[str, str] = {
    "(1)": "Euler-Lagrange, leg r_s",
    "(2)": "tau = sqrt(g/r_e) t",
    "(3)": "angular momentum about the stance foot",
    "(5)": "guard from the feet's positions",
    "(6)": "angular momentum about the new contact",
    "(7)": "energy integrals + resets",
    "(10)": "root of f(q) = q",
    "(11)": "from (5)",
    "(12)": "q_positive margin",
    "(13)": "= (12) divided by a positive factor (beta < 1, cos theta_1 > 0)",
    "(14)": "each branch exact when theta_1 < 0; omits theta_II > theta_1 (else the leg never "
    "extends) and the lift-off bound",
    "(15)": "= theta_1 < 0, but not needed: sets with theta_1 > 0 walk",
    "(16)": "omega_I > 0",
    "(17)": "exact: theta_II < theta_IV = theta_1 + phi0 (> phi0/2)",
    "(18)": "exact with q = q(n+1); with q(n) only at q^f",
    "(19)": "slope of the affine map",
    "(23)": "E_Delta = -(1/2) m g r_e beta^2 (1 - lambda)(q - q^f)",
    "existence-sufficient": "lift-off and theta_II <= theta_1 counterexamples",
    "existence-necessary": "(15) and (17) violated, still walks",
    "qf-decreases-with-beta": "no counterexample where the motion is defined",
    "qf-decreases-with-phi0": "no counterexample where the motion is defined",
    "qf-largest-at-theta-II-zero": "true of (10); theta_II = 0 is often not a gait",
    "stability-rate": "lambda = beta^2 cos^2 phi0, global on the feasible interval",
    "energy-change-rate": "E_Delta proportional to q - q^f",
    "energy-proportional-to-q": "affine, not proportional",
    "typical-gait-fig8": "simulation through the closed-form instants",
    "basin-whole-state-space": "(q_apex, q_liftoff], edges simulated",
    "theta-II-upper-limit": "exact limit theta_IV = 37.5 deg, not 22.5 deg",
    "notation-r-c": "r_c = r_e",
    "notation-theta-1": "theta_1 = theta_I",
}
"""One-phrase notes for the summary table."""


def _simulated_map_evidence(n: int = 30, seed: int = SEED + 1) -> dict[str, float]:
    """One simulated step from random feasible states: the map, the angles and energies."""
    rng = np.random.default_rng(seed)
    errs: dict[str, list[float]] = {k: [] for k in ("map", "theta_I", "E_c", "E_r", "E_r_next")}
    done = 0
    while done < n:
        beta = rng.uniform(0.3, 0.99)
        phi0 = rng.uniform(0.1, 1.4)
        theta_I, theta_IV = float(ile.theta_I(beta, phi0)), float(ile.theta_IV(beta, phi0))
        theta_II = theta_I + rng.uniform(0.05, 0.95) * (theta_IV - theta_I)
        lo = float(ile.q_apex_min(beta, theta_II, phi0))
        hi = float(ile.q_liftoff_max(beta, theta_II, phi0))
        if not (hi > max(lo, 0.0) > -1):
            continue
        q0 = max(lo, 0.0) + rng.uniform(0.05, 0.95) * (hi - max(lo, 0.0))
        res = run(beta, theta_II, phi0, q0, 1)
        if res.ended != "completed":
            continue
        ev = step_events(res.events, 0)
        q1 = float(res.q[1])
        cos_I, cos_II = math.cos(theta_I), math.cos(theta_II)
        paper9 = beta**2 * math.cos(phi0) ** 2 * q0 + 2 * math.cos(phi0) ** 2 * (
            cos_II * (1 / beta**2 - beta) - cos_I * (1 / beta - beta)
        )
        errs["map"].append(abs(paper9 - q1) / abs(q1))
        paper11 = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))
        errs["theta_I"].append(abs(paper11 - ev["I+"][0]) / max(abs(paper11), 1e-300))
        e_c = energy_at(*ev["III"], 1.0) - energy_at(*ev["II"], beta)
        e_r = energy_at(*ev["IV"], 1.0) - energy_at(*ev["I+"], beta)
        lin = (1 - beta**3) * cos_II - (beta - beta**3) * cos_I
        paper20 = -0.5 * (beta**2 - beta**4) * q0 + lin
        paper21 = 0.5 * beta**4 * math.sin(phi0) ** 2 * q0 + math.sin(phi0) ** 2 * lin
        paper18_next = 0.5 * q1 * math.tan(phi0) ** 2 * beta**2
        errs["E_c"].append(abs(paper20 - e_c) / abs(e_c))
        errs["E_r"].append(abs(paper21 - e_r) / abs(e_r))
        errs["E_r_next"].append(abs(paper18_next - e_r) / abs(e_r))
        done += 1
    return {k: max(v) for k, v in errs.items()} | {"runs": n}


def audit_equations(
    comparisons: dict[str, compare.Comparison], walking_violations: dict[str, int]
) -> list[Entry]:
    """Entries for (1)-(23) from the comparisons and the simulation."""
    sim = _simulated_map_evidence()
    notes = _equation_notes()
    sim_for = {
        "(7)": {"max rel. error of (7) vs one simulated step": sim["map"], "runs": sim["runs"]},
        "(9)": {"max rel. error of (9) vs one simulated step": sim["map"], "runs": sim["runs"]},
        "(11)": {
            "max rel. error of (11) vs simulated post-impact angle": sim["theta_I"],
            "runs": sim["runs"],
        },
        "(18)": {
            "max rel. error of (18) with q(n+1) vs simulated E(IV) - E(I, n+1)": sim["E_r_next"],
            "runs": sim["runs"],
        },
        "(20)": {"max rel. error vs simulated E(III) - E(II)": sim["E_c"], "runs": sim["runs"]},
        "(21)": {"max rel. error vs simulated E(IV) - E(I, n+1)": sim["E_r"], "runs": sim["runs"]},
    }
    entries = []
    for eq in EQUATIONS:
        c = comparisons[eq.id]
        evidence: dict[str, Any] = {
            "symbolic": {
                "residual": c.residual,
                "zero": c.symbolic_zero,
                "assumptions": c.assumptions,
            },
            "numeric": {
                "max_rel_error": c.numeric_max_rel_error,
                "samples": c.numeric_samples,
                "seed": compare.DEFAULT_SEED,
                "against": "generated/ile/",
            },
        }
        if c.restricted:
            evidence["restricted"] = c.restricted
        if eq.id in sim_for:
            evidence["simulation"] = sim_for[eq.id]
        if eq.id in walking_violations:
            evidence["simulation"] = {
                "simulated sets violating it that walk": walking_violations[eq.id]
            }
        entries.append(
            Entry(
                eq.id,
                eq.text,
                equation_verdict(c, walking_violations),
                evidence,
                notes[eq.id],
                paper=eq.latex,
                derived=c.derived,
            )
        )
    return entries


# --------------------------------------------------------------------------- claims


def _params_row(beta: float, theta_II: float, phi0: float, **extra: Any) -> dict[str, Any]:
    row = {
        "beta": _round(beta),
        "theta_II_deg": _round(math.degrees(theta_II)),
        "phi0_deg": _round(math.degrees(phi0)),
        "theta_I_deg": _round(math.degrees(float(ile.theta_I(beta, phi0)))),
        "theta_IV_deg": _round(math.degrees(float(ile.theta_IV(beta, phi0)))),
        "q_f": _round(float(ile.q_fixed(beta, theta_II, phi0))),
    }
    row.update(extra)
    return row


def existence_claims() -> tuple[Entry, Entry, dict[str, int], dict[str, Any]]:
    """Sufficiency and necessity of the printed conditions (12)-(17), with simulation."""
    rng = np.random.default_rng(SEED)
    n = DENSE_SAMPLES
    beta = rng.uniform(0.05, 0.995, n)
    phi0 = rng.uniform(0.02, np.pi / 2 - 0.02, n)
    theta_II = rng.uniform(-np.pi / 2 + 0.01, np.pi / 2 - 0.01, n)
    printed = compare.paper_conditions(beta, theta_II, phi0)
    all_printed = np.logical_and.reduce(list(printed.values()))
    walks = walk_mask(beta, theta_II, phi0)
    theta_I = ile.theta_I(beta, phi0)
    qf = ile.q_fixed(beta, theta_II, phi0)
    margins = dict(zip([c[0] for c in ile.CONDITIONS], ile.condition_margins(beta, theta_II, phi0)))
    lifts = ~(np.asarray(margins["stance_contact"]) >= 0)
    categories = {
        "printed, walks": all_printed & walks,
        "printed, lift-off": all_printed & ~walks & lifts & (theta_II > theta_I),
        "printed, theta_II <= theta_I": all_printed & (theta_II <= theta_I),
        "violates (15) only, walks": walks & ~printed["(15)"] & printed["(17)"],
        "violates (17) only, walks": walks & ~printed["(17)"] & printed["(15)"],
        "violates (15) and (17), walks": walks & ~printed["(15)"] & ~printed["(17)"],
        "violates (14), q^f > 0": ~printed["(14)"]
        & (qf > 0)
        & (theta_II > theta_I)
        & (theta_II < ile.theta_IV(beta, phi0)),
    }
    sims: dict[str, dict[str, Any]] = {}
    counterexamples: dict[str, list[dict[str, Any]]] = {}
    mismatch = 0
    for name, mask in categories.items():
        idx = np.flatnonzero(mask)
        pick = np.sort(rng.choice(idx, size=min(SIMS_PER_CATEGORY, idx.size), replace=False))
        outcomes: dict[str, int] = {}
        rows = []
        for i in pick:
            b, t2, p = float(beta[i]), float(theta_II[i]), float(phi0[i])
            q0 = float(qf[i])
            res = run(b, t2, p, q0, SIM_STEPS)
            ok = converged(res, q0)
            label = "walks" if ok else res.ended
            outcomes[label] = outcomes.get(label, 0) + 1
            if ok != bool(walks[i]):
                mismatch += 1
            if len(rows) < 3:
                rows.append(_params_row(b, t2, p, simulated=label, fails=failing_reason(b, t2, p)))
        sims[name] = {"analytic count": int(mask.sum()), "simulated": len(pick), **outcomes}
        counterexamples[name] = rows
    checked = {k: v["simulated"] for k, v in sims.items()}
    walking_violations = {
        "(15)": sims["violates (15) only, walks"].get("walks", 0)
        + sims["violates (15) and (17), walks"].get("walks", 0),
        "(17)": sims["violates (17) only, walks"].get("walks", 0)
        + sims["violates (15) and (17), walks"].get("walks", 0),
    }
    not_walking = sims["printed, lift-off"].get("lift-off", 0) + sims[
        "printed, theta_II <= theta_I"
    ].get("undefined", 0)
    common = {
        "dense sample": {
            "parameter sets": n,
            "seed": SEED,
            "ranges": "beta in (0.05, 0.995), phi0 in (0.02, pi/2 - 0.02) rad, "
            "|theta_II| < pi/2 - 0.01 rad",
            "satisfy printed (12)-(17)": int(all_printed.sum()),
            "walk (derived exact conditions)": int(walks.sum()),
            "printed but do not walk": int((all_printed & ~walks).sum()),
            "walk but violate a printed condition": int((~all_printed & walks).sum()),
        },
        "simulation": {
            "start": "q0 = q^f of (10)",
            "steps": SIM_STEPS,
            "walks means": "completed and still at q^f (rel. 1e-6)",
            "per category": sims,
            "simulated sets whose outcome disagrees with the derived conditions": mismatch,
            "total simulations": int(sum(checked.values())),
        },
    }
    sufficient = Entry(
        "existence-sufficient",
        "(12)-(17) are sufficient conditions for the existence of the fixed point (Sec. IV-B, VI)",
        "wrong" if not_walking > 0 else "equivalent",
        common,
        "Sets satisfying every printed condition still fail: the stance foot lifts off "
        "(normal force < 0, i.e. q^f > q_liftoff_max), or theta_II <= theta_1 so the stance "
        "leg never reaches the extension angle. Corrected set (all needed, together "
        "sufficient): q^f > q_apex_min (exact (14)), phi0 < pi/2, theta_1 < theta_II < "
        "theta_IV, and min normal force >= 0 over the step at q^f. 'undefined' in the "
        "simulation means the stance leg never reaches theta_II during the step (it starts "
        "beyond it), so the leg never extends and no energy is added: no gait of the model.",
        paper="Three sufficient conditions have to be satisfied for the existence of fixed point",
        derived=r"q_{apex} < q^f \le q_{liftoff},\ \theta_I < \theta_{II} < \theta_{IV},\ "
        r"\varphi_0 < \pi/2",
        counterexamples=counterexamples["printed, lift-off"]
        + counterexamples["printed, theta_II <= theta_I"],
    )
    necessary = Entry(
        "existence-necessary",
        "(12)-(17) 'have to be satisfied' (necessary) for a fixed point",
        "conservative" if sum(walking_violations.values()) > 0 else "equivalent",
        common,
        "Gaits violating (15) (theta_1 > 0: the walker starts ahead of the apex) or (17) "
        "(phi0/2 <= theta_II < theta_IV) walk in the simulation and stay at q^f; every "
        "walking set of the dense sample that violates a printed condition violates only "
        "(15) and/or (17). The others are necessary: without (12) / (13) there is no "
        "positive fixed point (f(q) - q = (lambda - 1)(q - q^f) < 0 for q > 0, so q falls "
        "each step); all simulated violations of (14) fail; (16) holds on the whole "
        "parameter domain.",
        paper="Three sufficient conditions have to be satisfied",
        derived=r"\text{(15) and (17) are not necessary}",
        counterexamples=counterexamples["violates (15) only, walks"]
        + counterexamples["violates (17) only, walks"],
    )
    return sufficient, necessary, walking_violations, {"categories": sims}


@functools.cache
def _qf_expr() -> sm.Expr:
    return model.derive().quantities["q_fixed"].expr


def _monotone_claim(
    which: str, samples: dict[str, np.ndarray], defined: np.ndarray, walks: np.ndarray
) -> Entry:
    symbol = {"beta": model.beta, "phi0": model.phi0}[which]
    deriv = sm.lambdify((model.beta, model.theta_II, model.phi0), sm.diff(_qf_expr(), symbol))
    d = np.asarray(deriv(samples["beta"], samples["theta_II"], samples["phi0"]), float)
    bad_defined = np.flatnonzero(defined & (d >= 0))
    bad_any = np.flatnonzero((samples["qf"] > 0) & (d >= 0) & ~defined)
    rows = [
        _params_row(
            float(samples["beta"][i]),
            float(samples["theta_II"][i]),
            float(samples["phi0"][i]),
            derivative=float(d[i]),
        )
        for i in bad_defined[:3]
    ]
    outside = [
        _params_row(
            float(samples["beta"][i]),
            float(samples["theta_II"][i]),
            float(samples["phi0"][i]),
            derivative=float(d[i]),
        )
        for i in bad_any[:2]
    ]
    label = {"beta": "beta (Fig. 5)", "phi0": "phi0 (Fig. 7)"}[which]
    return Entry(
        f"qf-decreases-with-{which}",
        f"q^f decreases with {label}",
        "equivalent" if bad_defined.size == 0 else "wrong",
        {
            "symbolic": {"derivative": f"d q^f / d {which} of (10), exact (sympy.diff)"},
            "numeric": {
                "samples": int(samples["beta"].size),
                "defined (theta_1 < theta_II < theta_IV, q^f > 0)": int(defined.sum()),
                "walking": int(walks.sum()),
                "derivative >= 0 where defined": int(bad_defined.size),
                "derivative >= 0 where walking": int((walks & (d >= 0)).sum()),
                "derivative >= 0 with q^f > 0 outside the defined range": int(bad_any.size),
            },
        },
        "Holds over the whole range where the model's motion is defined and q^f > 0 "
        "(assumption: theta_1 < theta_II < theta_IV). "
        + (
            f"Outside it ({bad_any.size} sampled sets with theta_II beyond theta_IV or "
            "below theta_1) the formula can increase; those are not gaits."
            if bad_any.size
            else ""
        ),
        paper=f"q^f decreases with an increase in {which}",
        derived=rf"\partial q^f / \partial {sm.latex(symbol)} < 0",
        counterexamples=rows + outside,
    )


def _theta_II_claim(rng: np.random.Generator) -> Entry:
    qf = _qf_expr()
    k = (
        2
        * sm.cos(model.phi0) ** 2
        * (1 - model.beta**3)
        / (model.beta**2 * (1 - model.beta**2 * sm.cos(model.phi0) ** 2))
    )
    residual = sm.simplify(sm.diff(qf, model.theta_II) + k * sm.sin(model.theta_II))
    n_pairs, n_grid = 2000, 721
    beta = rng.uniform(0.05, 0.995, n_pairs)
    phi0 = rng.uniform(0.02, np.pi / 2 - 0.02, n_pairs)
    grid = np.linspace(-np.pi / 2 + 0.01, np.pi / 2 - 0.01, n_grid)
    b2, t2 = np.meshgrid(beta, grid, indexing="ij")
    p2 = np.broadcast_to(phi0[:, None], b2.shape)
    w = walk_mask(b2, t2, p2)
    has = w.any(axis=1)
    zero_walks = walk_mask(beta, 0.0, phi0)
    bad = np.flatnonzero(has & ~zero_walks)
    q = np.where(w, ile.q_fixed(b2, t2, p2), -np.inf)
    best = grid[np.argmax(q, axis=1)]
    theta_I = ile.theta_I(beta, phi0)
    rows = [
        _params_row(
            float(beta[i]),
            0.0,
            float(phi0[i]),
            theta_II_of_largest_walking_qf_deg=math.degrees(float(best[i])),
            at_theta_II_0=failing_reason(float(beta[i]), 0.0, float(phi0[i])),
        )
        for i in bad[:4]
    ]
    return Entry(
        "qf-largest-at-theta-II-zero",
        "q^f is largest at theta_II = 0 (Fig. 6, Sec. VI)",
        "incomplete"
        if (residual == 0 and bad.size)
        else ("identical" if residual == 0 else "wrong"),
        {
            "symbolic": {
                "d q^f / d theta_II + K sin(theta_II)": str(residual),
                "K": "2 cos^2(phi0)(1 - beta^3) / (beta^2 (1 - beta^2 cos^2 phi0)) > 0",
            },
            "numeric": {
                "(beta, phi0) pairs": n_pairs,
                "theta_II grid points": n_grid,
                "pairs with a walking theta_II": int(has.sum()),
                "of which theta_II = 0 does not walk": int(bad.size),
                "of those, theta_1 > 0 (theta_II = 0 is never reached)": int(
                    (theta_I[bad] > 0).sum()
                ),
                "of those, the stance foot lifts off at theta_II = 0": int(
                    (theta_I[bad] <= 0).sum()
                ),
            },
        },
        "As a property of formula (10) it is exact: q^f depends on theta_II only through "
        "K cos(theta_II) with K > 0, so theta_II = 0 maximises it (a cosine, not the "
        "'second order relationship' of the text except near 0). Missing: theta_II = 0 must "
        "itself be a gait. When theta_1 > 0 it is never reached, and at small beta / large "
        "phi0 its q^f lifts the stance foot off; then the largest walking q^f lies at an edge "
        "of the walking theta_II range.",
        paper=r"the optimal leg extension angle theta_II = 0 yields a maximum fixed point q^f",
        derived=r"\partial q^f/\partial\theta_{II} = -K\sin\theta_{II},\ K > 0",
        counterexamples=rows,
    )


def _stability_claims() -> tuple[Entry, Entry, dict[str, Any]]:
    f = model.derive().facts
    lam = f["stride.eigenvalue"]
    slope = sm.diff(f["stride.stride_map"], model.q)
    res_lam = sm.simplify(slope - model.beta**2 * sm.cos(model.phi0) ** 2)
    change = f["energy.change"] / (model.m * model.g * model.r_e)
    res_e = sm.simplify(
        sm.cancel(change + model.beta**2 / 2 * (1 - lam) * (model.q - f["stride.q_fixed"]))
    )
    rng = np.random.default_rng(SEED + 2)
    rows, lam_err, e_err, runs = [], 0.0, 0.0, 0
    sets = [(FIG_BETA, FIG_THETA_II, FIG_PHI0)]
    while len(sets) < 8:
        b, p = rng.uniform(0.5, 0.98), rng.uniform(0.2, 1.3)
        t_I, t_IV = float(ile.theta_I(b, p)), float(ile.theta_IV(b, p))
        t2 = t_I + rng.uniform(0.1, 0.9) * (t_IV - t_I)
        if walk_mask(np.array(b), np.array(t2), np.array(p)):
            sets.append((b, t2, p))
    trajectories = []
    for b, t2, p in sets:
        qf = float(ile.q_fixed(b, t2, p))
        lo = max(float(ile.q_apex_min(b, t2, p)), 0.0)
        hi = float(ile.q_liftoff_max(b, t2, p))
        lam_v = b**2 * math.cos(p) ** 2
        for q0 in (lo + 0.02 * (qf - lo), hi - 0.02 * (hi - qf)):
            res = run(b, t2, p, q0, 12)
            runs += 1
            qs = res.q
            dev = qs - qf
            keep = np.abs(dev[:-1]) > 1e-4 * qf
            ratios = dev[1:][keep] / dev[:-1][keep]
            lam_err = max(lam_err, float(np.max(np.abs(ratios - lam_v))))
            e_theta_I = float(ile.theta_I(b, p))
            energy = b**2 * qs / 2 + b * math.cos(e_theta_I)
            e_delta = np.diff(energy)
            keep_e = np.abs(e_delta[:-1]) > 1e-4 * b**2 * qf
            e_ratio = e_delta[1:][keep_e] / e_delta[:-1][keep_e]
            e_err = max(e_err, float(np.max(np.abs(e_ratio - lam_v))))
            if (b, t2, p) == sets[0]:
                trajectories.append(qs.tolist())
        rows.append(_params_row(b, t2, p, eigenvalue=lam_v))
    stab = Entry(
        "stability-rate",
        "the fixed point is asymptotically stable; perturbations decay at rate beta^2 cos^2 phi0",
        "identical" if (res_lam == 0 and lam_err < 1e-5) else "wrong",
        {
            "symbolic": {"df/dq - beta^2 cos^2 phi0": str(res_lam)},
            "simulation": {
                "runs (12 steps, starting near both basin edges)": runs,
                "max |(q_n+1 - q^f)/(q_n - q^f) - lambda|": lam_err,
            },
        },
        "The map is affine with slope lambda = beta^2 cos^2 phi0 in (0, 1) for 0 < beta < 1, "
        "0 < phi0 < pi/2: every feasible perturbation decays geometrically and monotonically "
        "(no overshoot, lambda > 0). Stability is global on the feasible interval, not only "
        "local.",
        paper="the eigenvalue of the jacobian J is within the unit circle. The fixed point is "
        "asymptotically stable",
        derived=sm.latex(lam),
        counterexamples=[],
    )
    energy = Entry(
        "energy-change-rate",
        "E_Delta goes to zero at the same rate beta^2 cos^2 phi0 (Sec. IV-E)",
        "equivalent" if (res_e == 0 and e_err < 1e-5) else "wrong",
        {
            "symbolic": {
                "E_Delta/(m g r_e) + (beta^2/2)(1 - lambda)(q - q^f)": str(res_e),
            },
            "simulation": {
                "runs": runs,
                "max |E_Delta(n+1)/E_Delta(n) - lambda| (E from the simulated states)": e_err,
            },
        },
        "E_Delta = -(1/2) m g r_e beta^2 (1 - lambda)(q - q^f): proportional to the distance "
        "from the fixed point, so it shrinks by lambda per step (assumption: q^f from (10)).",
        paper="E_Delta will approach zero with the same rate",
        derived=r"E_\Delta = -\tfrac12 m g r_e \beta^2 (1-\lambda)(q - q^f)",
        counterexamples=rows[:3],
    )
    return stab, energy, {"fig8_q_sequence": trajectories}


def _energy_proportional_claim(s: dict[str, np.ndarray]) -> Entry:
    c_val = ile.energy_constant(s["beta"], s["theta_II"], s["phi0"], 1.0, 1.0, 1.0)
    e_c0 = ile.energy_complement(s["beta"], s["theta_II"], s["phi0"], 0.0, 1.0, 1.0, 1.0)
    nonzero = int((np.abs(e_c0) > 1e-12).sum())
    i = int(np.argmax(np.abs(e_c0)))
    return Entry(
        "energy-proportional-to-q",
        "E_c and E_r are proportional to the state variable q (after (20) and (21))",
        "wrong" if nonzero else "identical",
        {
            "numeric": {
                "samples": int(s["beta"].size),
                "samples with E_c(q = 0) != 0": nonzero,
                "max |C| / (m g r_e)": float(np.max(np.abs(c_val))),
            }
        },
        "E_c, E_r and E_Delta are affine in q (a q + b with b != 0), as the text itself says "
        "just before (20) ('linear functions'); 'proportional' is wrong. Corrected: 'affine "
        "in q'.",
        paper="E_c is proportional to the state variable q",
        derived=r"E_c = a q + b,\ b = m g r_e[(1-\beta^3)\cos\theta_{II} - (\beta-\beta^3)"
        r"\cos\theta_I] \ne 0",
        counterexamples=[
            _params_row(
                float(s["beta"][i]),
                float(s["theta_II"][i]),
                float(s["phi0"][i]),
                E_c_at_q0_over_mgr=float(e_c0[i]),
            )
        ],
    )


def _fig8_claim() -> tuple[Entry, dict[str, Any]]:
    b, t2, p = FIG_BETA, FIG_THETA_II, FIG_PHI0
    qf = float(ile.q_fixed(b, t2, p))
    res = run(b, t2, p, qf, 2)
    ev = step_events(res.events, 0)
    analytic = {
        "I": (float(ile.theta_I(b, p)), math.sqrt(qf)),
        "II": (t2, math.sqrt(float(ile.omega_II_squared(b, t2, p, qf)))),
        "III": (t2, b**2 * math.sqrt(float(ile.omega_II_squared(b, t2, p, qf)))),
        "IV": (float(ile.theta_IV(b, p)), math.sqrt(float(ile.omega_IV_squared(b, t2, p, qf)))),
    }
    err = max(
        abs(ev[k][j] - analytic[k][j]) / max(abs(analytic[k][j]), 1e-300)
        for k in analytic
        for j in (0, 1)
        if abs(analytic[k][j]) > 0
    )
    ret = abs(ev["I+"][1] - analytic["I"][1]) / analytic["I"][1]
    entry = Entry(
        "typical-gait-fig8",
        "Fig. 8: a stable gait cycle for theta_II = 0, beta = 0.8, phi0 = 45 deg; heelstrike "
        "returns the system to its initial conditions",
        "equivalent" if (res.ended == "completed" and err < 1e-8 and ret < 1e-8) else "wrong",
        {
            "simulation": {
                "q^f": qf,
                "max rel. error of simulated instants I-IV vs closed form": err,
                "rel. error of omega after heelstrike vs omega_I": ret,
                "walks": walk_mask(np.array(b), np.array(t2), np.array(p)).item(),
            }
        },
        "Reproduced (figure fig8): the simulated cycle passes through the closed-form instants "
        "I-IV and closes at heelstrike. theta_I = -7.48 deg, theta_IV = 37.52 deg.",
        paper="Fig. 8",
        derived=rf"q^f = {qf:.6f}",
    )
    return entry, {"analytic_instants": analytic}


def _basin_claims() -> tuple[Entry, Entry, dict[str, Any]]:
    from vsw.models.ile.basin import basin, check_edges_by_simulation

    b, p = FIG_BETA, FIG_PHI0
    grid = np.radians(np.arange(-30.0, 40.01, 0.5))
    result = basin(b, p, grid)
    checks = check_edges_by_simulation(result, n_samples=7)
    has = np.isfinite(result.q_min) & np.isfinite(result.q_max)
    q_apex = ile.q_apex_min(b, grid, p)
    q_lift = ile.q_liftoff_max(b, grid, p)
    err_min = float(np.max(np.abs(result.q_min[has] - q_apex[has]) / q_apex[has]))
    err_max = float(np.max(np.abs(result.q_max[has] - q_lift[has]) / q_lift[has]))
    paper14 = compare.paper_apex_bound(np.full_like(grid, b), grid, np.full_like(grid, p))
    err_14 = float(np.max(np.abs(paper14[has] - result.q_min[has]) / result.q_min[has]))
    theta_I, theta_IV = float(ile.theta_I(b, p)), float(ile.theta_IV(b, p))
    edges_ok = all(c.ok for c in checks)
    basin_entry = Entry(
        "basin-whole-state-space",
        "Fig. 9: the basin of attraction is the whole feasible state space, bounded on the "
        "left by (14) (falling backward) and on the right by the stance foot lifting off",
        "equivalent" if (edges_ok and err_min < 1e-9 and err_max < 1e-9) else "wrong",
        {
            "numeric": {
                "theta_II grid (deg)": "-30 : 0.5 : 40",
                "max rel. |basin left edge - exact (14)|": err_min,
                "max rel. |basin left edge - printed (14)|": err_14,
                "max rel. |basin right edge - q_liftoff_max|": err_max,
            },
            "simulation": {
                "edge checks (just inside converges, just outside falls / lifts off)": len(checks),
                "passed": int(sum(c.ok for c in checks)),
            },
        },
        "Exact: f is affine with slope in (0, 1), so f(q) lies between q and q^f and the "
        "feasible interval q_apex_min < q <= q_liftoff_max maps into itself whenever q^f is "
        "inside it: the basin is the whole interval (assumption: the gait walks). The left "
        "edge equals printed (14) here because theta_1 < 0; the right edge is the normal-force "
        "bound, which the paper's existence conditions omit.",
        paper="Fig. 9",
        derived=r"(q_{apex}, q_{liftoff}]",
    )
    gait = has
    upper = float(np.degrees(grid[gait].max()))
    lower = float(np.degrees(grid[gait].min()))
    limit_entry = Entry(
        "theta-II-upper-limit",
        "Fig. 9: the upper limit of theta_II is determined by (13) and (17)",
        "conservative" if upper > math.degrees(p) / 2 else "equivalent",
        {
            "numeric": {
                "(17) limit phi0/2 (deg)": math.degrees(p) / 2,
                "exact limit theta_IV (deg)": math.degrees(theta_IV),
                "largest grid theta_II with a basin (deg)": upper,
                "smallest grid theta_II with a basin (deg)": lower,
                "theta_1 (deg), the missing lower limit": math.degrees(theta_I),
            }
        },
        "For beta = 0.8, phi0 = 45 deg gaits exist up to theta_II < theta_IV = 37.52 deg, "
        "beyond the (17) limit of 22.5 deg; (13) is not active there. The lower limit is "
        "theta_II > theta_1 = -7.48 deg (not (14)).",
        paper="The upper limitation of leg extension angle theta_II is determined by (13) and (17)",
        derived=r"\theta_I < \theta_{II} < \theta_{IV}",
        counterexamples=[
            _params_row(
                b,
                math.radians(30.0),
                p,
                walks=bool(walk_mask(np.array(b), np.array(math.radians(30.0)), np.array(p))),
                simulated=(
                    "walks"
                    if converged(
                        run(
                            b,
                            math.radians(30.0),
                            p,
                            float(ile.q_fixed(b, math.radians(30.0), p)),
                            SIM_STEPS,
                        ),
                        float(ile.q_fixed(b, math.radians(30.0), p)),
                    )
                    else "fails"
                ),
            )
        ],
    )
    data = {
        "theta_II": grid,
        "q_min": result.q_min,
        "q_max": result.q_max,
        "q_fixed": result.q_fixed,
        "paper14": paper14,
        "checks": checks,
        "theta_I": theta_I,
        "theta_IV": theta_IV,
    }
    return basin_entry, limit_entry, data


def _notation_claims() -> list[Entry]:
    printed_1 = [
        e.id for e in EQUATIONS if any("theta_1" in s or "omega_1" in s for s in e.sources)
    ]
    printed_I = [e.id for e in EQUATIONS if any("theta_I)" in s for s in e.sources)]
    return [
        Entry(
            "notation-r-c",
            "Fig. 4 caption: r_s, r_c are the stance leg lengths before and after extension",
            "notation",
            {"text": {"caption": "r_c", "body and equations (2)-(4), (18), (20)-(23)": "r_e"}},
            "The caption's r_c is the text's r_e (extended leg); beta = r_s / r_e everywhere "
            "else. Same physics; the derivation uses r_e.",
            paper="r_s, r_c: the length of the stance leg before and after leg extension",
            derived=r"r_c \equiv r_e,\ \beta = r_s/r_e",
        ),
        Entry(
            "notation-theta-1",
            "theta_1 / omega_1 in (5)-(14) versus theta_I in the text and (20)-(23)",
            "notation",
            {"text": {"theta_1 / omega_1 in": printed_1, "theta_I in": printed_I}},
            "Both name the stance angle (and rate) at instant I; the derivation and this audit "
            "use theta_I for both (paper_check.compare.PAPER_TO_DERIVED).",
            paper="theta_1, omega_1 (eq. 5-14) and theta_I (text, eq. 20-23)",
            derived=r"\theta_I,\ \omega_I",
        ),
    ]


def audit_claims() -> tuple[list[Entry], dict[str, int], dict[str, Any]]:
    """All audited claims, the walking violations per printed condition, and figure data."""
    sufficient, necessary, walking_violations, ex_data = existence_claims()
    rng = np.random.default_rng(SEED + 3)
    n = 100_000
    beta = rng.uniform(0.05, 0.995, n)
    phi0 = rng.uniform(0.02, np.pi / 2 - 0.02, n)
    theta_II = rng.uniform(-np.pi / 2 + 0.01, np.pi / 2 - 0.01, n)
    qf = ile.q_fixed(beta, theta_II, phi0)
    defined = (
        (theta_II > ile.theta_I(beta, phi0)) & (theta_II < ile.theta_IV(beta, phi0)) & (qf > 0)
    )
    samples = {"beta": beta, "phi0": phi0, "theta_II": theta_II, "qf": qf}
    walks = walk_mask(beta, theta_II, phi0)
    mono_beta = _monotone_claim("beta", samples, defined, walks)
    mono_phi0 = _monotone_claim("phi0", samples, defined, walks)
    theta_claim = _theta_II_claim(rng)
    stab, energy, stab_data = _stability_claims()
    prop = _energy_proportional_claim(compare.sample_parameters(2000, SEED + 4))
    fig8, fig8_data = _fig8_claim()
    basin_entry, limit_entry, basin_data = _basin_claims()
    claims = [
        sufficient,
        necessary,
        mono_beta,
        mono_phi0,
        theta_claim,
        stab,
        energy,
        prop,
        fig8,
        basin_entry,
        limit_entry,
        *_notation_claims(),
    ]
    data = {"existence": ex_data, "stability": stab_data, "fig8": fig8_data, "basin": basin_data}
    return claims, walking_violations, data


def run_audit() -> Audit:
    """Run every check of the audit (no files written)."""
    comparisons = compare.compare_all()
    claims, walking_violations, data = audit_claims()
    equations = audit_equations(comparisons, walking_violations)
    data["gaps"] = gait_gaps()
    settings = {
        "seed": SEED,
        "numeric samples per equation": compare.DEFAULT_SAMPLES,
        "numeric tolerance": NUMERIC_TOL,
        "dense sample for the existence claims": DENSE_SAMPLES,
        "simulations per existence category": SIMS_PER_CATEGORY,
        "simulator": "vsw.models.ile.simulate (DOP853, rtol 1e-10, atol 1e-12, event refinement)",
    }
    from paper_check.hzd_ile import audit_hzd

    return Audit(equations, claims, data, settings, audit_hzd())


def paper_latex(eq_id: str) -> str:
    """Printed LaTeX of one equation."""
    return EQUATION_BY_ID[eq_id].latex


def gait_gaps() -> list[dict[str, Any]]:
    """Parts of the plotted curves of Fig. 5-7 where no valid gait exists.

    Each gap is a contiguous run of non-walking points, with the failing physical
    conditions at its ends and middle, and the time-domain simulation at its middle
    (started at q^f, three steps).

    Returns
    -------
    list of dict
        Keys ``figure, curve, from, to, fails, simulated``.
    """
    gaps = []
    for name in ("fig5", "fig6", "fig7"):
        for label, x, b, t, p in curves(name):
            ok = walks(b, t, p)
            edges = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]))
            for start, stop in zip(edges[::2], edges[1::2]):
                idx = (start, (start + stop - 1) // 2, stop - 1)
                fails = sorted(
                    {r for i in idx for r in failing_reason(b[i], t[i], p[i]).split(", ")}
                )
                i = idx[1]
                qf = float(ile.q_fixed(b[i], t[i], p[i]))
                if qf > 0:
                    res = run(b[i], t[i], p[i], qf, 3)
                    simulated = "walks" if converged(res, qf) else res.ended
                else:
                    simulated = "q^f <= 0"
                gaps.append(
                    {
                        "figure": name,
                        "curve": plain(label),
                        "from": float(x[start]),
                        "to": float(x[stop - 1]),
                        "fails": ", ".join(fails),
                        "simulated at the middle": simulated,
                    }
                )
    return gaps


Legend = tuple[list[Any], list[str]]
