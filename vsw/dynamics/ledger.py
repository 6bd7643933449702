"""The energy ledger of one step: where every joule of a gait goes.

Over a step the kinetic energy changes by what the forces do:

* in each phase, **gravity** (the potential's fall, ``V(start) - V(end)``, in the phase's
  chart) and **each actuator** (by the model's name for it: ``Model.actuators``) that
  holds a moving coordinate (the integral of its power,
  the generated ``<phase>_actuator_power``: generalised force times the held value's
  rate; its positive and negative parts apart);
* at each event, the **loss**: at an impact the work of the ground's impulse at the new
  contact (Kelvin: the impulse, the walker's change of momentum, times the mean of the
  contact point's velocities before and after, the latter zero), at a lock the whole
  kinetic energy change; and the kinetic energy of the bodies' velocity jumps
  (``1/2 sum m |v+ - v-|^2 + 1/2 sum I (w+ - w-)^2``, by body: Carnot's loss, equal to the
  loss where no actuator's impulse does work);
* at each event the **ground's impulse** (forward, up): the walker's change of momentum.
  At an instantaneous extension the ground must give it through a push and then a pull of
  unbounded size (the leg's net impulse along itself is zero), and a net impulse that
  points down means the foot is pulled on balance: the model assumes it held;
* the **actuators' impulsive work** (the rest of the event's energy change: a jump's
  whole change, kinetic and potential: an instantaneous actuation lifts the walker in no
  time, with no work of gravity; an actuator holding a coordinate through an impact; zero
  for a workless impact or lock).

The ledger states each term and the **balance**: gravity's and the actuators' work less
the losses, less the height the events' actuators raised the walker by, less the kinetic
energy gained over the step (zero on a period-one gait). The balance checks the phases'
terms only (the quadrature of the power against the energies at the phase's ends): at an
event the actuators' work is *defined* as what the energy change leaves once the loss is
counted. That remainder is checked elsewhere: it vanishes at a workless impact (the
ground's work equals the energy change and Carnot's loss, three computations), it is the
ILE paper's (20) at its extension and the torso's impulse times its mean relative rate on
the torso walker (tests/test_ledger.py, tests/test_torso_walker.py).

Body velocities are the complex-step derivative of the generated positions along the rates
(exact to rounding); the phase integrals are Gauss-Legendre quadrature of the dense output
on each of the solver's steps.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import EventRecord, HybridModel, Orbit, PhasePiece
from vsw.runtime.errors import ConvergenceError

__all__ = ["energy_ledger"]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(8)
"""Gauss-Legendre with 8 nodes on each of the solver's steps: the dense output is a
polynomial on each step (degree 7 for DOP853), so the power, a smooth function of it, is
integrated to far below the balance's 1e-12 seen on the models' gaits."""

_STEP = 1e-30
"""The complex step: the derivative's error is of order step**2, far below rounding."""


def _kinetic_potential(model: HybridModel, phase: str, params: Sequence[float],
                       state: np.ndarray) -> tuple[float, float]:  # fmt: skip
    """(T, V) of a state: V is the energy with the rates at zero (T is quadratic in them)."""
    energy = model.function(f"{phase}_energy")
    at_rest = np.concatenate([state[: model.n], np.zeros(model.n)])
    potential = float(energy(*params, *at_rest))
    return float(energy(*params, *state)) - potential, potential


def _rate_of(model: HybridModel, name: str, params: Sequence[float],
             state: np.ndarray) -> np.ndarray:  # fmt: skip
    """The rate of change of the generated configuration function ``name`` (a tuple of
    positions) along the state's rates: its complex-step derivative."""
    n = model.n
    shifted = state[:n] + 1j * _STEP * state[n:]
    value = model.function(name)(*params, *shifted, *state[n:])
    rate = np.imag(np.array(value, dtype=complex)) / _STEP
    if not np.all(np.isfinite(rate)):
        raise ConvergenceError(f"{model.name}: the rate of {name} is not finite")
    return rate


def _bodies(
    model: HybridModel, phase: str, params: Sequence[float], state: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Masses, inertias and velocities (vx, vy, angular rate) of the phase's bodies."""
    velocities = _rate_of(model, f"{phase}_positions", params, state).reshape(-1, 3)
    inertia = np.array([float(v) for v in model.function(f"{phase}_inertias")(*params, *state)])
    return inertia[0::2], inertia[1::2], velocities


def _jumps(model: HybridModel, event: dict, params: Sequence[float],
           before: np.ndarray, after: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Each body's velocity jump at an event (in the order of the phase after's bodies)
    and its mass and inertia (columns)."""
    masses, inertias, v_after = _bodies(model, event["target"], params, after)
    _, _, v_before = _bodies(model, event["source"], params, before)
    if event.get("bodies") is not None:
        v_before = v_before[list(event["bodies"])]
    return v_after - v_before, np.column_stack([masses, inertias])


def _phase_terms(model: HybridModel, params: Sequence[float], piece: PhasePiece) -> dict[str, Any]:
    """Gravity's work and each actuator's over a phase of the step."""
    record = model.phases[model.phase_index[piece.phase]]
    start, end = piece.states(np.array([piece.start, piece.end]))
    t_start, v_start = _kinetic_potential(model, piece.phase, params, start)
    t_end, v_end = _kinetic_potential(model, piece.phase, params, end)
    out: dict[str, Any] = {
        "phase": piece.phase,
        "duration": piece.end - piece.start,
        "kinetic_change": t_end - t_start,
        "gravity_work": v_start - v_end,
        "actuators": {},
    }
    names = record.get("actuators", ())
    if names and piece.end > piece.start:
        steps = [t for solution, a, b in piece.segments for t in solution.ts if a <= t <= b]
        edges = np.unique(np.array([piece.start, *steps, piece.end], dtype=float))
        half = np.diff(edges) / 2
        times = (edges[:-1, None] + half[:, None] * (_NODES[None, :] + 1)).ravel()
        weights = (half[:, None] * _WEIGHTS[None, :]).ravel()
        states = piece.states(times).T
        power = np.asarray(
            model.function(f"{piece.phase}_actuator_power")(*params, *states), dtype=float
        ).reshape(len(names), -1)
        named = model.spec.get("actuator_names", {})
        for name, p in zip(names, power):
            out["actuators"][named.get(name, name)] = {
                "work": float(weights @ p),
                "positive": float(weights @ np.maximum(p, 0.0)),
                "negative": float(weights @ np.minimum(p, 0.0)),
            }
    return out


def _event_terms(
    model: HybridModel, params: Sequence[float], record: EventRecord
) -> dict[str, Any]:
    """An event's loss and impulsive actuator work."""
    event = next(e for e in model.events if e["name"] == record.name)
    t_before, v_before = _kinetic_potential(model, event["source"], params, record.state_before)
    t_after, v_after = _kinetic_potential(model, event["target"], params, record.state_after)
    kinetic_change = t_after - t_before
    names = model.spec.get("actuator_names", {})
    out: dict[str, Any] = {"event": record.name, "reset": event["reset"],
                           "kinetic_change": kinetic_change}  # fmt: skip
    # The actuators acting at a jump (those of the coordinates it moves) or catching at a
    # lock (a stopped coordinate the model names an actuator for: its loss is their work).
    actuated = [names.get(h, h) for h in event.get("actuated", ())
                if event["reset"] == "jump" or h in names]  # fmt: skip
    jump, inertia = _jumps(model, event, params, record.state_before, record.state_after)
    # Gravity gives no impulse in an instant and every other force is internal, so the
    # ground's impulse (at the new contact or the stance foot) is the walker's change of
    # momentum, forward and up.
    impulse = inertia[:, 0] @ jump[:, :2]
    out["ground_impulse"] = [float(impulse[0]), float(impulse[1])]
    if event["reset"] in ("impact", "lock"):
        # The configuration does not change (an impact's chart moves to the new contact,
        # which changes V's reference, not the walker's height): only T changes.
        per_body = 0.5 * (inertia[:, 0] * (jump[:, 0] ** 2 + jump[:, 1] ** 2)
                          + inertia[:, 1] * jump[:, 2] ** 2)  # fmt: skip
        out["velocity_jump_energy"] = float(np.sum(per_body))
        out["velocity_jump_energy_by_body"] = [float(v) for v in per_body]
        if event["reset"] == "impact":
            # Kelvin: an impulse does the work of its size times the mean of its point's
            # velocities before and after; the ground's impulse at the new contact (the
            # walker's change of momentum) meets a point at rest after it.
            contact = _rate_of(model, f"event_{record.name}_contact", params,
                               record.state_before)  # fmt: skip
            out["loss"] = float(-0.5 * impulse @ contact)
        else:
            out["loss"] = -kinetic_change  # a lock's impulse stops its joint: all lost
        target = model.phases[model.phase_index[event["target"]]]
        out["actuator_work"] = kinetic_change + out["loss"]
        out["actuators"] = tuple(names.get(h, h) for h in target.get("actuators", ()))
        if actuated:
            out["caught_by"] = tuple(actuated)
    else:
        # A jump (or a continuous transition) in the same chart: the actuator raises or
        # lowers the walker as it changes its speed, all of it the actuator's work.
        out["loss"] = 0.0
        out["potential_change"] = v_after - v_before
        out["actuator_work"] = kinetic_change + out["potential_change"]
        out["actuators"] = tuple(actuated)
    return out


def energy_ledger(model: HybridModel, params: Sequence[float], orbit: Orbit) -> dict[str, Any]:
    """The energy ledger of one step of ``orbit`` (module docstring): per phase and event
    the terms, their totals, and the balance (the terms' sum less the kinetic energy
    gained over the step, zero up to the integration's error), absolute and relative to
    ``scale``, the largest term."""
    start = np.array(list(orbit.state.values()), dtype=float)
    pieces, events, ended = model.continuous_walk(params, start, 1)
    if ended != "completed":
        raise ConvergenceError(f"{model.name}: the gait's step ended with {ended}")
    phases = [_phase_terms(model, params, piece) for piece in pieces]
    event_terms = [_event_terms(model, params, record) for _, record in events]
    actuators: dict[str, dict[str, float]] = {}
    for phase in phases:
        for name, work in phase["actuators"].items():
            total = actuators.setdefault(name, {"work": 0.0, "positive": 0.0, "negative": 0.0})
            for key in total:
                total[key] += work[key]
    gravity = sum(p["gravity_work"] for p in phases)
    continuous = sum(a["work"] for a in actuators.values())
    impulsive = sum(e["actuator_work"] for e in event_terms)
    losses = sum(e["loss"] for e in event_terms)
    raised = sum(e.get("potential_change", 0.0) for e in event_terms)
    t_start, _ = _kinetic_potential(model, pieces[0].phase, params, start)
    last = events[-1][1]
    t_end, _ = _kinetic_potential(model, model.step_event["target"], params, last.state_after)
    gained = t_end - t_start
    # Gravity does no work in an instant: what a jump's actuator raises the walker by is
    # its work stored as height, which gravity's work in the phases then gives back.
    balance = gravity + continuous + impulsive - losses - raised - gained
    scale = max(abs(gravity), abs(continuous), abs(impulsive), losses, t_start, 1e-300)
    return {
        "phases": phases,
        "events": event_terms,
        "totals": {
            "gravity_work": gravity,
            "actuator_work_continuous": continuous,
            "actuator_work_impulsive": impulsive,
            "actuators": actuators,
            "losses": losses,
            "potential_raised_at_events": raised,
            "kinetic_gained": gained,
        },
        "balance": balance,
        "scale": scale,
        "balance_relative": balance / scale,
    }
