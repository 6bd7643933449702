"""The conditions a gait must meet, with their margins: every model's, from its failures,
and the closed-form ones of the models whose derivation states them.

* :func:`gait_conditions`: along a periodic gait (one step simulated by the compiled
  integrator, sampled as the SciPy route samples it), each of the model's failures
  (``HYBRID["failures"]``: falling back, falling forward, the stance foot lifting off,
  ...) as a margin that is positive while the walk goes on: the least of
  ``-direction * guard`` over the step, in the guard's unit. A gait the simulation confirmed
  has every margin positive; how close to zero says how near the gait is to failing. Then
  the conditions a model assumes and reports without enforcing them
  (``HYBRID["conditions"]``: the kneed walker's stance knee pressed into its stop), whose
  margins may be negative on a gait.
* :func:`closed_form_conditions`: for a model whose derivation gives its fixed point and
  existence conditions in closed form (``CONDITIONS`` and ``fixed_point_conditions`` in its
  generated package: the ILE's (12)-(17), the TLE's), the closed-form fixed point and each
  condition's margin there, with its unit (``CONDITION_UNITS``), equation and status.
  This is what says why a model has no gait where the closed form exists but a condition
  fails (the TLE's leg that would have to pull).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from vsw.dynamics.batch import simulator
from vsw.dynamics.hybrid import HybridModel, Orbit

__all__ = ["SAMPLES", "closed_form_conditions", "gait_conditions"]

SAMPLES = 400
"""Samples of one step per gait (the integrator's steps bounded by period / SAMPLES, and
every event instant)."""


def gait_conditions(model: HybridModel, params: Sequence[float], orbit: Orbit) -> list[dict]:
    """Each failure's margin along ``orbit`` (name, meaning, margin, unit, holds), then each
    condition the model reports without enforcing it (``HYBRID["conditions"]``: a gait
    walks where it fails; ``ends_walk`` says which is which)."""
    state = np.array(list(orbit.state.values()))
    # The compiled integrator's samples are the SciPy route's to rounding (a few 1e-13 in
    # the state), at under a hundredth of its time (benchmark case 10).
    trajectory = simulator(model).sampled_step(params, state, orbit.period / SAMPLES)
    interior_only = {c["name"] for c in model.spec.get("conditions", ()) if c.get("interior")}
    least: dict[str, float] = {}
    profiles: dict[str, np.ndarray] = {}
    for k, phase in enumerate(model.phases):
        in_phase = trajectory.phase == k
        samples = trajectory.states[in_phase]
        if not len(samples):
            continue
        checks = [(*f, False) for f in (*phase["failures"], *phase.get("conditions", ()))]
        checks += [(*f, True) for f in phase.get("start_failures", ())]
        for name, function, direction, at_start in checks:
            at = samples[:1] if at_start else samples  # checked where the phase begins
            with np.errstate(all="ignore"):
                guard = np.asarray(model.module.__dict__[function](*params, *at.T), float)
            margin = -direction * np.broadcast_to(guard, len(at))
            if name in interior_only:
                profiles.setdefault(name, np.full(len(trajectory.t), np.nan))[in_phase] = margin
                continue
            least[name] = min(least.get(name, math.inf), float(np.min(margin)))
    for name, profile in profiles.items():
        inside = _least_inside(profile, trajectory.t)
        if inside is not None:
            least[name] = inside
    out = []
    records = [(f, True) for f in model.spec["failures"]]
    records += [(c, False) for c in model.spec.get("conditions", ())]
    for record, ends_walk in records:
        margin = least.get(record["name"])
        samples = f"({len(trajectory.t)} samples)"
        how = (
            f"least between its first rise and its last fall over the step {samples}"
            if record["name"] in interior_only
            else "where its phase begins"
            if record.get("at_start")
            else f"least over the step {samples}"
        )
        out.append({
            "name": record["name"],
            "meaning": record["meaning"],
            "margin": margin,
            "unit": record["unit"],
            "holds": None if margin is None else bool(margin > 0),
            "ends_walk": ends_walk,
            "how": how,
        })  # fmt: skip
    return out


def _least_inside(margin: np.ndarray, t: np.ndarray) -> float | None:
    """The least of a margin over a step's interior, for a quantity the step's events put
    at zero at its ends (the swing foot's height): the samples of the first and last
    instants left out, then the run over which it first rises (the foot's lift) and the
    run over which it last falls (its landing); what remains is where it comes closest to
    failing in between (a unimodal profile keeps its peak alone)."""
    values = margin[(t > t[0]) & (t < t[-1])]
    if not len(values):
        return None
    if not np.all(np.isfinite(values)):
        return math.nan  # as the least over the step of the other conditions would be
    first, last = 0, len(values) - 1
    while first < last and values[first + 1] >= values[first]:
        first += 1
    while last > first and values[last - 1] >= values[last]:
        last -= 1
    return float(np.min(values[first : last + 1]))


def has_closed_form(model: HybridModel) -> bool:
    """Whether the model's package gives its fixed point and conditions in closed form."""
    module = model.module
    return hasattr(module, "CONDITIONS") and hasattr(module, "fixed_point_conditions")


def closed_form_conditions(model: HybridModel, params: Sequence[float]) -> dict[str, Any] | None:
    """The closed-form fixed point (q = rate**2 just after the step event), its eigenvalue
    and every condition's margin there; None for a model without them."""
    if not has_closed_form(model):
        return None
    module = model.module
    # numpy scalars, not Python floats: at the edges of the parameter intervals a power
    # underflows to 0 or overflows, which Python floats raise (ZeroDivisionError,
    # OverflowError) and IEEE arithmetic carries on as inf and NaN, reported below.
    with np.errstate(all="ignore"):
        values = module.fixed_point_conditions(*(np.float64(v) for v in params))
        q_f, eigenvalue, *margins = (float(v) for v in values)
    units = getattr(module, "CONDITION_UNITS", {})
    conditions = []
    walks = math.isfinite(q_f)
    for (name, equation, strict, status, physical, meaning), margin in zip(
        module.CONDITIONS, margins
    ):
        holds = bool(margin > 0 if strict else margin >= 0) if math.isfinite(margin) else False
        if physical:
            walks = walks and holds
        conditions.append({
            "name": name, "equation": equation, "margin": margin, "unit": units.get(name, ""),
            "holds": holds, "strict": strict, "physical": physical, "status": status,
            "meaning": meaning,
        })  # fmt: skip
    return {"q_fixed": q_f, "eigenvalue": eigenvalue, "walks": walks, "conditions": conditions}


def failing(record: dict[str, Any]) -> list[dict[str, Any]]:
    """The physical closed-form conditions that fail, worst (most negative) first."""
    bad = [c for c in record["conditions"] if c["physical"] and not c["holds"]]
    return sorted(bad, key=lambda c: c["margin"] if math.isfinite(c["margin"]) else -math.inf)
