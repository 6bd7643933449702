"""``python -m paper_check --model point-mass-biped``: the point-mass biped's least-work
gaits (``vsw optimize``) beside the inverted-pendulum walking Srinivasan & Ruina (2006)
found optimal at low speed, with its cost derived here, and the ILE's price: the ILE's gait
against the least-work gait of its own body at the same speed and step length
(docs/models/powered_walking.md).

The inverted-pendulum gait with legs ``l`` long at ``+-alpha`` (``sin alpha = d / 2l``):
the hip moves on a circular arc, the leg does no work, and at the step the velocity
``v_e`` (perpendicular to the trailing leg) is turned to the mirror direction by a push-off
``P`` along the trailing leg and a heel-strike ``H`` along the leading leg. Keeping the
horizontal component, ``P = H = m v_e tan alpha``; the push-off comes first and makes the
velocity horizontal, ``v_e / cos alpha``, so its work is ``m v_e**2 (1 / cos(alpha)**2 - 1)
/ 2 = m v_e**2 tan(alpha)**2 / 2`` a step, which the heel-strike takes. ``v_e`` follows
from the step time ``d / V``: the pendulum's time from ``-alpha`` to ``alpha`` is ``2
integral_0^alpha dtheta / sqrt(v_e**2 / l**2 + 2 g (cos alpha - cos theta) / l)``, solved
for ``v_e`` (SciPy's quad and brentq). Nothing of it comes from the collocation.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from scipy.integrate import IntegrationWarning, quad
from scipy.optimize import brentq, least_squares, minimize_scalar

from paper_check.rows import Row, table
from vsw.dynamics.ledger import energy_ledger
from vsw.models import load
from vsw.synthesis.powered import PoweredGait, Request, optimize

__all__ = ["inverted_pendulum_gait", "point_mass_biped"]

SOURCES = {
    "SR06": "Srinivasan & Ruina, Computer optimization of a minimal biped model discovers "
    "walking and running, Nature 439:72-75, 2006: the finding that inverted-pendulum walking "
    "with impulsive push-off and heel-strike is the least-work gait at low speed, and "
    "impulsive running at higher speeds (its numbers were not at hand)",
    "IP": "the inverted-pendulum gait's cost and push-off derived in this report (module "
    "docstring of paper_check/powered.py): m v_e^2 tan^2(alpha) / 2 a step, v_e by quadrature",
    "ILE": "the ILE model (the paper; vsw's closed forms): its gait and its energy ledger's "
    "actuator work a step (the leg's extension)",
}

LOW_SPEED = ((0.6, 0.2), (0.6, 0.4), (0.6, 0.6), (0.6, 0.8), (0.4, 0.4), (0.8, 0.5))
"""(step length d, speed V), scaled (m = g = l = 1): where inverted-pendulum walking is."""
FASTER = (0.9, 1.0, 1.2)
"""Speeds above that range at d = 0.6."""
ILE_GAITS = ((0.8, 0.0, 45.0), (0.9, 0.0, 45.0), (0.9, 0.0, 30.0), (0.8, 10.0, 45.0),
             (0.95, 0.0, 40.0))  # fmt: skip
"""(beta, theta_II in degrees, phi0 in degrees) of the ILE gaits priced."""
GRID_SPEEDS = (0.3, 0.4, 0.5, 0.6)
GRID_STEPS = (0.5, 0.6, 0.7)
"""The ILE's price over speeds and step lengths (scaled: r_e = g = 1)."""
THETA_II_STEP = math.radians(5.0)
"""The ILE's cheapest gait at a speed and step length: its extension angle scanned by this
from 0 both ways (to 85 degrees, or the first angle past a gait with none)."""
NODES = 40
LONGEST_INTERVAL = 0.05
"""Intervals a phase of the coarse mesh: at least ``NODES``, and no longer than this (in
sqrt(l/g)). Inverted-pendulum walking holds the leg at its length; between the knots the
leg force's power wiggles about zero on the scheme's cubic, by O(h^3), and the cost
prices it: at 20 intervals the slowest gait's cost changed by 8e-4 to 40, and at 40 it
was still 1.4e-5 above the derived cost."""
SWITCH_STARTS = (0.35, 0.65)
"""Where the optimiser starts the legs' switch point (over d) when it chooses it: either
side of the midpoint, which the model without the choice holds."""
SR06_ACTUATORS = ("leg_force", "push_off", "heel_strike")
"""Srinivasan & Ruina's model: the leg force and the step's impulses (no stance torque)."""


def inverted_pendulum_gait(speed: float, step: float, m: float = 1.0, g: float = 1.0,
                           l: float = 1.0) -> tuple[float, float, float] | None:  # fmt: skip
    """(positive work a step, push-off impulse, speed at the step) of inverted-pendulum
    walking at ``speed`` with steps ``step`` long (module docstring), or None where that
    gait does not exist: the leg would have to pull. Its force, ``m (g cos(theta) - l
    omega**2)``, is least at the step, where the arc is steepest and fastest."""
    alpha = math.asin(step / (2 * l))

    def duration(omega_e: float) -> float:
        def integrand(theta: float) -> float:
            return 1 / math.sqrt(omega_e**2 + 2 * g / l * (math.cos(alpha) - math.cos(theta)))

        return 2 * quad(integrand, 0, alpha, epsabs=0.0, epsrel=1e-10, limit=200)[0]

    slowest = math.sqrt(2 * g / l * (1 - math.cos(alpha)))  # just passes the apex
    with warnings.catch_warnings():
        # Near the slowest arc the integrand peaks at the apex and quad warns: those
        # evaluations only bracket the root, which lies well away from them.
        warnings.simplefilter("ignore", IntegrationWarning)
        omega_e = brentq(lambda w: duration(w) - step / speed, slowest * (1 + 1e-9), 100.0,
                         xtol=1e-15, rtol=1e-15)  # fmt: skip
    if g * math.cos(alpha) - l * omega_e**2 < 0:
        return None
    v_e = l * omega_e
    return 0.5 * m * v_e**2 * math.tan(alpha) ** 2, m * v_e * math.tan(alpha), v_e


def _optimum(step: float, speed: float, shortest: float | None = None,
             switch: float | None = None) -> PoweredGait:  # fmt: skip
    """The least-work gait with SR06's actuators (legs down to ``shortest``: l_min); with
    ``switch``, of ``point_mass_biped_switch`` from that switch point (sigma)."""
    biped = load("point_mass_biped" if switch is None else "point_mass_biped_switch")
    nodes = max(NODES, math.ceil(step / speed / LONGEST_INTERVAL))
    request = Request("work", target_speed=speed, nodes=nodes, use=SR06_ACTUATORS)
    values = ({"d": step} | ({} if shortest is None else {"l_min": shortest})
              | ({} if switch is None else {"sigma": switch}))  # fmt: skip
    return optimize(biped, biped.parameters(values), request)


def _switch_optimum(step: float, speed: float, shortest: float) -> PoweredGait:
    """The least-work gait of the same body with the legs' switch point chosen by the
    optimiser too, the best of the starts :data:`SWITCH_STARTS` (an optimal one first)."""
    found = [_optimum(step, speed, shortest, switch) for switch in SWITCH_STARTS]
    return min(found, key=lambda gait: (gait.status != "optimal", gait.cost))


def fastest_inverted_pendulum_walk(step: float) -> float:
    """The speed above which inverted-pendulum walking with steps ``step`` long needs a
    pulling leg (m = g = l = 1): where its leg force at the step reaches zero."""
    return brentq(lambda v: 1.0 if inverted_pendulum_gait(v, step) is None else -1.0,
                  0.05, 5.0, xtol=1e-6)  # fmt: skip


def _walking_rows(cases: Sequence[tuple[float, float]]) -> list[Row]:
    rows = []
    for step, speed in cases:
        cost, push, _ = inverted_pendulum_gait(speed, step)  # every case is below its limit
        gait = _optimum(step, speed)
        legs = np.hypot(gait.states[0][:, 0], gait.states[0][:, 1])
        note = (f"{gait.status}{': ' + gait.reason if gait.reason else ''}; leg length "
                f"{legs.min():.7f} to {legs.max():.7f}; the leg force's positive work "
                f"{gait.work['stance.leg_force']['positive']:.2g}")  # fmt: skip
        where = f"d = {step:g}, V = {speed:g}"
        rows.append(Row(f"least positive work a step, {where}", "IP", cost, gait.cost,
                        1e-5 * cost, note))  # fmt: skip
        rows.append(Row(f"push-off impulse, {where}", "IP", push,
                        gait.impulses["heelstrike.push_off"], 1e-5 * push,
                        f"heel-strike {gait.impulses['heelstrike.heel_strike']:.8g}"))  # fmt: skip
    return rows


def _faster_table(speeds: Sequence[float]) -> str:
    lines = ["| V | status | least positive work found | inverted-pendulum walking's | "
             "shortest leg | largest leg force on the mesh | push-off |",
             "| --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for speed in speeds:
        gait = _optimum(0.6, speed)
        legs = np.hypot(gait.states[0][:, 0], gait.states[0][:, 1])
        walking = inverted_pendulum_gait(speed, 0.6)
        walking_text = "none: the leg would pull" if walking is None else f"{walking[0]:.6g}"
        lines.append(f"| {speed:g} | {gait.status} | {gait.cost:.6g} | {walking_text} | "
                     f"{legs.min():.4f} | {np.max(gait.inputs[0][:, 0]):.3g} | "
                     f"{gait.impulses['heelstrike.push_off']:.3g} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def _ile_table(cases: Sequence[tuple[float, float, float]]) -> str:
    ile = load("ile")
    lines = ["| beta | theta_II (deg) | phi0 (deg) | V | d | ILE's work a step | its cost of "
             "transport | inverted-pendulum walking's work | ILE / it | least work found | "
             "ILE / it | status |",
             "|" + " --- |" * 12]  # fmt: skip
    for beta, theta_II, phi0 in cases:
        params = ile.parameters({"beta": beta, "theta_II": math.radians(theta_II),
                                 "phi0": math.radians(phi0)})  # fmt: skip
        (gait,) = ile.fixed_points(params)
        work = energy_ledger(ile, params, gait)["totals"]["actuator_work_impulsive"]
        speed, step = gait.speed, gait.step_length
        walking_gait = inverted_pendulum_gait(speed, step)
        if walking_gait is None:
            raise AssertionError(f"ILE gait {beta, theta_II, phi0}: no inverted-pendulum walk")
        walking = walking_gait[0]
        best = _optimum(step, speed, shortest=beta)  # the ILE's legs: from beta r_e to r_e
        lines.append(f"| {beta:g} | {theta_II:g} | {phi0:g} | {speed:.6f} | {step:.6f} | "
                     f"{work:.6f} | {work / step:.6f} | {walking:.6f} | {work / walking:.3f} | "
                     f"{best.cost:.6f} | {work / best.cost:.3f} | {best.status} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def _ile_gait_at(speed: float, step: float, theta_II: float, start: Sequence[float]):
    """The ILE gait with extension angle ``theta_II`` at this speed and step length: its
    parameters, with (beta, phi0) by least squares on the closed forms from ``start``, and
    its gait; None where there is none (no fixed point, two or more, the existence
    conditions fail, or no (beta, phi0) matches to 1e-10 from that start)."""
    ile = load("ile")

    def gait_of(z):
        try:
            params = ile.parameters({"beta": z[0], "theta_II": theta_II, "phi0": z[1]})
            gaits = ile.fixed_points(params)
        except ValueError:  # outside the parameters' intervals
            return None, None
        return (params, gaits[0]) if len(gaits) == 1 else (None, None)

    def mismatch(z):
        _, gait = gait_of(z)
        return [10.0, 10.0] if gait is None else [gait.speed - speed, gait.step_length - step]

    fit = least_squares(mismatch, start, bounds=([0.3, 0.05], [0.999, 1.5]), xtol=1e-15,
                        ftol=1e-15, gtol=1e-15)  # fmt: skip
    if max(abs(r) for r in fit.fun) > 1e-10:
        return None
    params, gait = gait_of(fit.x)
    return params, gait


def _ile_work(params, gait) -> float:
    """The ILE's actuator work a step (its ledger: the leg's extension)."""
    return energy_ledger(load("ile"), params, gait)["totals"]["actuator_work_impulsive"]


def cheapest_ile_gait(speed: float, step: float):
    """VSW's most favourable gait at this speed and step length: the ILE gait of least
    actuator work a step over the extension angle (scanned by :data:`THETA_II_STEP` from 0
    both ways, each gait's (beta, phi0) continued from its neighbour's, to 85 degrees or
    until a gait is followed by none; then Brent's method between the best scan
    point's neighbours), as (params, gait, work, edge): ``edge`` True where the least is
    at the last angle with a gait (no interior minimum: the angle where the gaits end is
    then found to 1e-8 by a march from gait to gait, and its gait taken). None where no
    angle scanned has a gait."""
    found = []
    for direction in (1, -1):
        start = [0.9, 2 * math.asin(min(step / 2, 0.99))]
        for k in range(0 if direction == 1 else 1, 18):
            theta_II = direction * k * THETA_II_STEP
            at = _ile_gait_at(speed, step, theta_II, start)
            if at is None:
                if found and any(f[0] * direction >= 0 for f in found):
                    break
                continue
            start = [at[0][0], at[0][2]]
            found.append((theta_II, _ile_work(*at), start))
    if not found:
        return None
    found.sort()
    k = min(range(len(found)), key=lambda i: found[i][1])
    edge = k in (0, len(found) - 1)
    theta_II, start = found[k][0], found[k][2]
    if edge and len(found) > 1:
        # The gaits end beyond it: march outward from gait to gait, halving the step after
        # each failure (a solve from a neighbour closer than the step succeeds where one
        # from afar does not), to the last angle with a gait.
        outward = 1 if k == len(found) - 1 else -1
        stride = THETA_II_STEP / 10
        while stride > 1e-8:
            at = _ile_gait_at(speed, step, theta_II + outward * stride, start)
            if at is None:
                stride /= 2
            else:
                theta_II, start = theta_II + outward * stride, [at[0][0], at[0][2]]
    if not edge:

        def work(angle: float) -> float:
            at = _ile_gait_at(speed, step, angle, start)
            return math.inf if at is None else _ile_work(*at)

        best = minimize_scalar(work, bounds=(found[k - 1][0], found[k + 1][0]),
                               method="bounded", options={"xatol": 1e-6})  # fmt: skip
        if best.fun < found[k][1]:
            theta_II = best.x
    at = _ile_gait_at(speed, step, theta_II, start)
    if at is None:  # Brent's angle, solved from another start than its own: the scan's
        theta_II, at = found[k][0], _ile_gait_at(speed, step, found[k][0], found[k][2])
    params, gait = at
    return params, gait, _ile_work(params, gait), edge


def _ile_grid_table(speeds: Sequence[float], steps: Sequence[float]) -> str:
    lines = ["| V | d | VSW's cheapest gait: beta, theta_II (deg), phi0 (deg) | its work a step "
             "| its cost of transport | inverted-pendulum walking's work | its cost of "
             "transport | VSW / it | least work found (legs down to beta) | VSW / it | "
             "status | the switch point chosen: sigma found, least work | status |",
             "|" + " --- |" * 13]  # fmt: skip
    for speed in speeds:
        for step in steps:
            ile = cheapest_ile_gait(speed, step)
            walking = inverted_pendulum_gait(speed, step)
            walking_text = ("none: the leg would pull | -" if walking is None else
                            f"{walking[0]:.6f} | {walking[0] / step:.6f}")  # fmt: skip
            if ile is None:
                lines.append(f"| {speed:g} | {step:g} | none (no ILE gait at theta_II "
                             f"scanned) | - | - | {walking_text} |" + " - |" * 6)  # fmt: skip
                continue
            params, gait, work, edge = ile
            beta, theta_II, phi0 = params
            ratio = "-" if walking is None else f"{work / walking[0]:.3f}"
            best = _optimum(step, speed, shortest=beta)
            switched = _switch_optimum(step, speed, shortest=beta)
            sigma = switched.parameters[-1]
            at_edge = (f" (where its gaits end: the extension {gait.durations[1]:.1g} before "
                       "heel-strike)" if edge else "")  # fmt: skip
            lines.append(f"| {speed:g} | {step:g} | {beta:.4f}, {math.degrees(theta_II):.2f}"
                         f"{at_edge}, {math.degrees(phi0):.2f} | {work:.6f} | {work / step:.6f} | "
                         f"{walking_text} | {ratio} | {best.cost:.6f} | "
                         f"{work / best.cost:.3f} | {best.status} | {sigma:.6f}, "
                         f"{switched.cost:.6f} | {switched.status} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def point_mass_biped(out: Path, quick: bool = False) -> list[Path]:
    """Write ``out/point-mass-biped.md`` (``quick``: two walking cases, one faster speed,
    one ILE gait and one cell of the price's grid)."""
    walking = _walking_rows(LOW_SPEED[:2] if quick else LOW_SPEED)
    text = [
        "# The point-mass biped's least-work gaits\n\n",
        "Generated by `python -m paper_check.walkers --model point-mass-biped`. The model: ",
        "derive/models/point_mass_biped.py (a point mass on two massless telescoping legs at ",
        "most l long, a leg force F >= 0, a push-off impulse along the trailing leg just ",
        "before the step and a heel-strike impulse along the new leg just after it; the legs ",
        "exchange roles where the hip passes midway between the feet). Scaled units: ",
        "m = g = l = 1, l_min = 0.5. Each gait: `vsw optimize --model point-mass-biped ",
        "--param d=D --minimize work --target-speed V --use leg_force --use push_off --use ",
        "heel_strike` (SR06's actuators: the stance torque held at zero; N and 2N ",
        f"intervals, N at least {NODES} and the coarser's intervals at most ",
        f"{LONGEST_INTERVAL:g} long; Hermite-Simpson, the leg force linear on each interval), ",
        "from a start that is no gait.\n\n",
        "".join(f"* [{k}] {v}\n" for k, v in SOURCES.items()),
        "\n## Inverted-pendulum walking at low speed (SR06), against its cost derived here\n\n",
        table(walking),
        "\nThe optimiser finds SR06's gait: the leg stays at its full length and does no ",
        "work, the push-off and heel-strike impulses are equal, and the least positive work ",
        "a step is the inverted-pendulum gait's.\n",
        "\n## Faster, d = 0.6\n\n",
        _faster_table(FASTER[:1] if quick else FASTER),
        "\nInverted-pendulum walking with steps of 0.6 exists up to V = ",
        f"{fastest_inverted_pendulum_walk(0.6):.4f}: faster, its leg would have to pull at ",
        "the step (the force m (g cos(alpha) - l omega_e^2) < 0). At 0.9, below that ",
        "limit, the optimiser finds a gait cheaper than it, and beyond it gaits all the ",
        "same. In them the ",
        "push-off goes, the leg shortens and the force concentrates on one knot in ",
        "mid-stance and its two intervals (its peak doubles when the mesh is halved: an ",
        "impulse), the leg unloaded (F near 0: a flight in all but name) around it: SR06's ",
        "impulsive running, in a model whose only impulses are at the step. The mesh ",
        "cannot resolve a mid-stance impulse and the result says `not-converged`: the ",
        "numbers are neither optima nor bounds, only a sign that inverted-pendulum walking ",
        "is not the least work at 0.9.\n",
        "\n## The ILE's price\n\n",
        "Each ILE gait (its closed forms; its energy ledger's actuator work a step, the ",
        "leg's extension) against the least positive work of its own body (the point-mass ",
        "biped with the ILE's r_e as l and its beta r_e as l_min) at the same speed and ",
        "step length, SR06's actuators. Costs of transport per weight and step length. ",
        "Inverted-pendulum walking is a gait of that body (an exact one, derived), so the ",
        "least work is at most its work and the ratio to it is a lower bound on the ILE's ",
        "price. The optimiser's `optimal` is a local optimum: its least work is a candidate ",
        "for the price, no more. The point-mass biped's legs exchange roles midway between ",
        "the feet, the ILE's do not: the optimum over every switch point can only be ",
        "lower (the last two columns of the grid table below price the body with the ",
        "switch point chosen too).\n\n",
        _ile_table(ILE_GAITS[:1] if quick else ILE_GAITS),
        "\n## The ILE's price over speeds and step lengths\n\n",
        "At each speed V and step length d (scaled: r_e = g = 1), VSW's most favourable ",
        "gait: the ILE gait of least actuator work a step over its extension angle ",
        "theta_II (scanned from 0 both ways by 5 degrees until the gaits end, each gait's ",
        "beta and phi0 solved from V and d on the closed forms, then Brent's method about ",
        "the best), against ",
        "inverted-pendulum walking (derived above: a gait of the same body, so VSW / it is ",
        "a lower bound on the price) and the optimiser's least work with legs from beta to ",
        "1 (the ILE's). Costs of transport per weight and step length. Where VSW's least ",
        "work is at the last angle with a gait, it is where the extension meets heel-strike ",
        "(the phase after it shrinks to nothing): the cheapest VSW gait extends the stance ",
        "leg at the end of the stance, where the optimum pushes off, and still costs more ",
        "than the optimum. The last two columns: the same body with the legs' switch point ",
        "chosen by the optimiser as well (`point-mass-biped-switch`, the hip at sigma d from ",
        "the stance foot when they exchange; the better of the starts sigma = ",
        f"{', '.join(f'{v:g}' for v in SWITCH_STARTS)}): where it switches and its least ",
        "work.\n\n",
        _ile_grid_table(
            GRID_SPEEDS[:1] if quick else GRID_SPEEDS, GRID_STEPS[:1] if quick else GRID_STEPS
        ),
    ]
    path = out / "point-mass-biped.md"
    path.write_text("".join(text))
    return [path]
