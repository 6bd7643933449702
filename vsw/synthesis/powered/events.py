"""The events of a powered step: the state after an event with its impulses (before the
reset, with the impact, after it), their work and the ground's impulses, for the NLP
(CasADi, :func:`event_map`, :func:`event_jacobian`) and for the re-simulation (numpy,
:func:`apply_impulses`, :func:`stopping_splits`)."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits.monodromy import saltation
from vsw.synthesis.powered.dynamics import flow_function, momentum_function
from vsw.synthesis.powered.objectives import positive_work_of_linear_power
from vsw.synthesis.powered.request import Request, impulse_names, impulses_usable
from vsw.synthesis.powered.variables import Constraints, Unknowns

__all__ = ["apply_impulses", "event_jacobian", "event_map", "stopping_splits"]


def event_jacobian(model: HybridModel, phase: str, event: dict, p: Any, v: Unknowns,
                   after: Any) -> Any:  # fmt: skip
    """d(state after the event)/d(state at the phase's end) along the perturbed motion: a
    perturbation ``dx`` meets the guard ``g`` ``dt = -g_x dx / (g_x f)`` later, so the
    state there moves by ``(I - f g_x / (g_x f)) dx`` (the saltation's projection; the
    inputs are functions of the phase's time, the next phase's start at the event), then
    the event's map (reset and impulses, the impulses fixed) by its Jacobian."""
    import casadi as ca

    end = v.knots[-1]
    rate = flow_function(model, phase)(p, end, v.u_knots[-1])
    slope = ca.jacobian(model.symbolic(f"event_{event['name']}_guard", p, end), end)
    return ca.mtimes(ca.jacobian(after, end), saltation(rate, slope, 2 * model.n))


def event_map(model: HybridModel, event: dict, p: Any, end: Any, v: Unknowns,
              g: Constraints, request: Request | None = None
             ) -> tuple[Any, Any, dict, dict, dict]:  # fmt: skip
    """The state after an event from the phase's last knot: the impulses applied before
    the reset (the rates jump by their gains), the reset with the impulse at its impact
    (the rates after gain its gains), those applied after; the impulses' positive work as
    the cost prices it and each impulse's positive and negative work.

    Impulses applied together in proportion move each one's ``along`` rate linearly
    from ``a`` to ``b``: its power goes linearly from ``iota a`` to ``iota b``, its work
    is ``iota (a + b) / 2`` (the kinetic energy's change) and its positive work
    :func:`positive_work_of_linear_power` of those ends, more than the net work where the
    rate reverses (an impulse that stops a shortening leg, then pushes it out, puts back
    as positive work what it first absorbed). Where the cost is the work each side's
    impulses are applied in two parts, first ``f iota`` (the split ``f`` in [0, 1] free
    for each impulse), then the rest, and each part's positive work is priced by two
    slacks ``s >= 0`` at its power's ends, at their mean: exact where the part's rate
    does not reverse, above it where it does, so the least priced split is the one that
    stops each reversing rate at the parts' junction, and the price is then the exact
    positive work of that schedule (the ledger's, which has the exact positive work of the
    split found, and the reported cost). The impulse applied with an impact does the work
    ``c iota^2 / 2``, never negative.

    Last, the ground's impulses on the walker over the event (its momentum's change):
    through the stance foot (the impulses before an impact's reset; a lock's impulse,
    which the foot takes too) and through the new foot (an impact, with what acts after
    it, and the stance foot's share of an impulse applied with the impact). At an impact,
    and at a change of phase where impulses act (a push at a chosen angle, through the
    stance foot), each must push (its normal part ``>= 0``: a constraint), within the
    friction cone of ``request.friction`` where it has one; a lock's is only reported
    (stopping a leg that lengthens pulls the foot: the instantaneous extension's
    idealisation, which the VSW biped shares) unless ``request.pushing_locks``."""
    import casadi as ca

    groups = impulse_names(model, event)
    n = model.n
    plus: dict = {}
    minus: dict = {}
    priced = 0
    x = end
    iota = v.impulses[0] if v.impulses else None
    splits = v.splits[0] if v.splits and v.splits[0].shape[0] else None
    offset = 0
    momentum_before = momentum_function(model, event["source"])
    ground = {}
    for side, names in zip(("before", "with", "after"), groups):
        stem = f"event_{event['name']}_impulse"
        j = iota[offset : offset + len(names)] if names else None
        if side == "with":  # the reset, and the impulse applied with its impact
            if groups[0]:  # the impulses before, through the stance foot
                ground["stance_foot"] = momentum_before(p, x) - momentum_before(p, end)
            reset_from = x
            reset = model.symbolic(f"event_{event['name']}_reset", p, x)
            if names:
                gains = model.symbolic(f"{stem}_gains_with", p, x)
                work = model.symbolic(f"{stem}_work_with", p, x) * j * j / 2
                parts = [(work, work)]
                reset = ca.vertcat(reset[:n], reset[n:] + gains * j)
            x = reset
        elif names:
            gains = ca.reshape(model.symbolic(f"{stem}_gains_{side}", p, x), len(names), n).T
            rates = functools.partial(model.symbolic, f"{stem}_rates_{side}", p)
            first = j if splits is None else splits[offset : offset + len(names)] * j
            middle = ca.vertcat(x[:n], x[n:] + ca.mtimes(gains, first))
            jumped = ca.vertcat(x[:n], x[n:] + ca.mtimes(gains, j))
            parts = [(first * rates(x), first * rates(middle))]
            if splits is not None:
                parts.append(((j - first) * rates(middle), (j - first) * rates(jumped)))
            x = jumped
        if not names:
            continue
        priced = priced + _price_parts(event, names, parts, v, offset, g, plus, minus)
        offset += len(names)
    # The reset and what follows it: through the new foot at an impact (with the stance
    # foot's share of an impulse at the impact), through the stance foot at a lock.
    key = "new_foot" if event["reset"] == "impact" else "stance_foot"
    change = momentum_function(model, event["target"])(p, x) - momentum_before(p, reset_from)
    ground[key] = change + ground.get(key, 0)
    _pushing_rows(event, groups, ground, key, request, g)
    return x, priced, plus, minus, {f"{event['name']}.{k}": i for k, i in ground.items()}


def _price_parts(event: dict, names: list[str], parts: list, v: Unknowns, offset: int,
                 g: Constraints, plus: dict, minus: dict) -> Any:  # fmt: skip
    """One side's impulses priced (:func:`event_map`): the ends of each part's power
    bounded by slacks into ``g`` where the cost is the work (the price their mean), else
    their exact positive work; each impulse's positive and negative work into ``plus`` and
    ``minus``. Returns the price."""
    import casadi as ca

    work = sum((a + b) / 2 for a, b in parts)
    positive_work = sum(positive_work_of_linear_power(a, b, ca) for a, b in parts)
    if v.s_impulses and v.s_impulses[0].shape[0]:
        count = len(names)
        slacks = v.s_impulses[0][4 * offset : 4 * (offset + count)]
        ends = ca.vertcat(*(end for part in parts for end in part))
        g.add(slacks[: ends.shape[0]] - ends, 0.0, math.inf)
        priced = ca.sum1(slacks[: ends.shape[0]]) / 2
    else:
        priced = ca.sum1(positive_work)
    for i, name in enumerate(names):
        plus[f"{event['name']}.{name}"] = positive_work[i]
        minus[f"{event['name']}.{name}"] = work[i] - positive_work[i]
    return priced


def _pushing_rows(event: dict, groups: tuple, ground: dict, key: str, request: Request | None,
                  g: Constraints) -> None:  # fmt: skip
    """The ground's impulses of an event pushing (normal part >= 0) and within the friction
    cone, into ``g``, where :func:`event_map` asks for them (``key``: the foot the reset
    acts through)."""
    # A foot is pushed, never pulled, by the ground: at an impact, at a change of phase
    # where the actuators act in an instant (a push at a chosen angle), and at a lock where
    # asked.
    acting = event["reset"] == "continuous" and impulses_usable(request, [*groups[0], *groups[2]])
    pushing = (event["reset"] == "impact" or acting
               or (request is not None and request.pushing_locks))  # fmt: skip
    friction = None if request is None else request.friction
    if pushing:
        for foot, impulse in ground.items():
            if foot == "stance_foot" and key != foot and not impulses_usable(request, groups[0]):
                continue  # the impulses before are held at zero: no impulse, no row
            g.add(impulse[1], 0.0, math.inf)
            if friction is not None and (event["reset"] == "impact" or acting):
                g.add(friction * impulse[1] - impulse[0], 0.0, math.inf)
                g.add(friction * impulse[1] + impulse[0], 0.0, math.inf)


def apply_impulses(model: HybridModel, event: dict, p: np.ndarray, state: np.ndarray,
                   iota: np.ndarray, splits: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The state after an event (its impulses before the reset, the reset with the impulse
    at its impact, those after) from the state before it, each impulse's work and, with
    ``splits`` (each impulse applied in two parts, :func:`event_map`), the ends of each
    part's power in the order of the NLP's impulse slacks (four an impulse, zero where
    unused): numpy's side of :func:`event_map`."""
    n = model.n
    x = np.asarray(state, dtype=float)
    iota = np.asarray(iota, dtype=float)
    fractions = np.ones(len(iota)) if splits is None else np.asarray(splits, dtype=float)
    works, ends = [], []
    offset = 0
    for side, names in zip(("before", "with", "after"), impulse_names(model, event)):
        stem = f"event_{event['name']}_impulse"
        count = len(names)
        j = iota[offset : offset + count]
        if side == "with":
            reset = np.array(model.function(f"event_{event['name']}_reset")(*p, *x), dtype=float)
            if names:
                gains = np.array(model.function(f"{stem}_gains_with")(*p, *x), dtype=float)
                work = float(model.function(f"{stem}_work_with")(*p, *x)) * j * j / 2
                works += list(work)
                ends += [*work, *work, *np.zeros(2 * count)]
                reset[n:] += gains.reshape(n) * j[0]
            x = reset
        elif names:
            gains = np.array(model.function(f"{stem}_gains_{side}")(*p, *x), dtype=float)
            gains = gains.reshape(n, count)
            rates = model.function(f"{stem}_rates_{side}")
            first = fractions[offset : offset + count] * j
            middle, jumped = x.copy(), x.copy()
            middle[n:] += gains @ first
            jumped[n:] += gains @ j
            at = [np.array(rates(*p, *y), float).reshape(-1) for y in (x, middle, jumped)]
            parts = [first * at[0], first * at[1], (j - first) * at[1], (j - first) * at[2]]
            works += list((parts[0] + parts[1] + parts[2] + parts[3]) / 2)
            ends += [value for part in parts for value in part]
            x = jumped
        offset += count
    return x, np.array(works), np.array(ends, dtype=float)


def stopping_splits(model: HybridModel, event: dict, p: np.ndarray, state: np.ndarray,
                    iota: np.ndarray) -> np.ndarray:  # fmt: skip
    """A start for each impulse's split (:func:`event_map`): where its rate reverses
    (applied whole, with the others in proportion), the fraction that stops it; else 1/2."""
    _x, _works, ends = apply_impulses(model, event, p, state, iota)
    splits = np.full(len(iota), 0.5)
    offset = 0
    for side, names in zip(("before", "with", "after"), impulse_names(model, event)):
        count = len(names)
        block = ends[4 * offset : 4 * (offset + count)].reshape(4, count)
        if side != "with":
            before, after = block[0], block[1]  # the whole impulse as the first part
            reverses = before * after < 0
            fraction = np.divide(before, before - after, out=np.full(count, 0.5),
                                 where=reverses)  # fmt: skip
            splits[offset : offset + count] = np.clip(fraction, 0.0, 1.0)
        offset += count
    return splits
