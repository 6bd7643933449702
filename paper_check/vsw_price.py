"""``python -m paper_check.walkers --model free-vsw-biped``: VSW's price on its own biped:
each VSW biped gait's actuator work a step against the least work found for the same body,
free in how it uses its leg and hip, at the same speed and step length
(docs/models/powered_walking.md).

The VSW biped's gaits: Newton (``periodic_orbit``) from the states ``vsw analyze`` lists
for them, their work from the energy ledger (the extension's, ``leg and held hip``: its
net work, which is at most its positive work, so the ratio below is at most VSW's true
one). The body's gaits: ``vsw optimize --model free-vsw-biped --minimize work`` at the
VSW gait's speed and step, the ground pushing within a friction cone of 1 and the swing
foot at least 0.02 l sin(pi s) above the ground (no scuffing), then verified
(``vsw.synthesis.powered.verify``): the periodic motion of the walker driven by the optimum's inputs
and its work integrated along it. That verified gait is a gait of the body, so its work
bounds the body's least work from above at its speed and step (within 1e-4 of the
targets), and the VSW gait's work over it bounds VSW's price from below. The mesh's own
number is shown beside it (the mesh prices each interval's positive work from above,
so it cannot hide a power that changes sign inside an interval).

The defaults' gait is optimised again on finer meshes (:data:`REFINEMENT`), each gait
verified, with the leg force's largest value and when: where that value grows as the
mesh refines, the least work wants a leg action faster than any mesh resolves. Last, the
same gait of the body with a push at a chosen angle (``free-vsw-biped-push``) from the
starts of :data:`PUSH_STARTS`: whether the optimiser uses the impulse that limit points to.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsw.dynamics.ledger import energy_ledger
from vsw.models import load
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.design import DesignRequest, GaitDesign, design
from vsw.synthesis.powered import Request, input_names, optimize, walker_weight
from vsw.synthesis.powered.verify import VerifiedGait, verify

__all__ = ["free_vsw_biped"]

VSW_GAITS = (
    ({}, (-0.252572, 0.684685, 0.506767, -0.97655)),
    ({"beta": 0.9}, (-0.136929, 0.469983, 0.610843, -0.0500801)),
    ({"beta": 0.9}, (-0.261105, 0.516618, 0.449664, -0.475193)),
    ({"theta_II": 0.1}, (0.0526276, 0.645345, 0.872497, -0.0161405)),
    ({"mu": 0.2}, (-0.235263, 0.67938, 0.494822, -1.03816)),
    ({"beta": 0.85}, (-0.044882, 0.556434, 0.745363, -0.03972)),
    ({"beta": 0.85, "theta_II": -0.1}, (-0.243631, 0.600774, 0.49658, -0.689207)),
    ({"beta": 0.95}, (-0.191141, 0.368972, 0.482995, 0.034656)),
    ({"beta": 0.95, "theta_II": -0.1}, (-0.244054, 0.397974, 0.403154, -0.159436)),
    ({"beta": 0.95}, (-0.319635, 0.446688, 0.344081, -0.27649)),
    ({"beta": 0.8}, (-0.359553, 0.724481, 0.425742, -1.140032)),
)
"""VSW biped parameters (beside its defaults) and a gait's state just after heelstrike
(theta, psi, theta_dot, psi_dot) as `vsw analyze` lists it: Newton's start."""
FRICTION = 1.0
CLEARANCE = 0.02
NODES = 20
STARTS = 4
"""``--starts`` of each body gait of the first table and the grid: the least squared-input
step and three perturbations of its inputs, each refined; the best is kept (optimal
first, then IPOPT's success, then the least work on the fine mesh: the landscape has
local optima close together, docs/models/powered_walking.md)."""
REFINEMENT = (20, 40, 80)
"""The defaults' gait optimised with these ``--nodes`` (on 40, 80 and 160 intervals)."""
STROKE_MARGIN = 0.02
"""The body's shortest leg is beta - this (in l): the VSW biped's stroke and a little more."""
PUSH_STARTS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
"""Starts of ``theta_push`` (free-vsw-biped-push) for the defaults' gait, 10 ``--nodes``."""
GRID_SPEEDS = (0.25, 0.3, 0.35, 0.4)
GRID_STEPS = (0.65, 0.75, 0.85)
"""The grid of speeds and step lengths: at each cell a VSW biped designed to walk there."""
GRID_FIXED = {"theta_II": 0.0, "mu": 0.1}
"""What the grid's robots share: each cell designs beta and b/l (``vsw design``)."""


@dataclass(frozen=True)
class _VswGait:
    """A VSW biped gait: its label, speed, step length, actuators' work a step and its
    extension's ground impulse (forward, up)."""

    label: str
    speed: float
    step_length: float
    work: float
    extension_impulse: tuple[float, float]
    weight: float


@functools.cache
def _vsw_gait(values: tuple, guess: tuple) -> _VswGait:
    """The VSW biped's gait near ``guess`` (``values``: its parameters' (name, value)
    pairs) and its ledger's numbers; cached: the end-stop table prices the defaults'
    again."""
    biped = load("vsw_biped")
    params = biped.parameters(dict(values))
    pieces, _events, ended = biped.continuous_walk(params, np.array(guess), 1)
    if ended != "completed":
        raise ConvergenceError(f"vsw-biped: the listed gait's step ended with {ended}")
    orbit = biped.periodic_orbit(params, np.array(guess), [p.end - p.start for p in pieces])
    ledger = energy_ledger(biped, params, orbit)
    totals = ledger["totals"]
    forward, up = next(e["ground_impulse"] for e in ledger["events"] if "ground_impulse" in e)
    return _VswGait(", ".join(f"{k} {v:g}" for k, v in values) or "defaults", orbit.speed,
                    orbit.step_length,
                    totals["actuator_work_impulsive"] + totals["actuator_work_continuous"],
                    (forward, up), walker_weight(biped, params))  # fmt: skip


def _body_gait(values: dict, speed: float, step: float, model: str = "free_vsw_biped",
               nodes: int = NODES, starts: int = 1):  # fmt: skip
    """The body's least-work gait found at (speed, step) on ``2 nodes`` intervals from
    ``starts`` starts and its verification (or why there is none)."""
    body = load(model)
    shared = {k: v for k, v in values.items() if k != "theta_II"}
    beta = body.parameters(shared)[0]
    # The VSW biped's leg is beta l to l long: the body's stroke that and STROKE_MARGIN
    # more (a landing exactly at the stroke's end would start on its failure's guard).
    params = body.parameters({**shared, "l_min": beta - STROKE_MARGIN})
    request = Request("work", speed, step, nodes, friction=FRICTION, clearance=CLEARANCE,
                      starts=starts)  # fmt: skip
    gait = optimize(body, params, request)
    try:
        return gait, verify(body, params, gait)
    except ConvergenceError as exc:
        return gait, str(exc).split(": ", 1)[-1]


def _row(values: dict, guess: Sequence[float]) -> str:
    vsw = _vsw_gait(tuple(values.items()), tuple(guess))
    gait, verified = _body_gait(values, vsw.speed, vsw.step_length, starts=STARTS)
    forward, up = vsw.extension_impulse
    head = (f"| {vsw.label} | {vsw.speed:.6f} | {vsw.step_length:.6f} | {vsw.work:.6f} | "
            f"{forward:.4f}, {up:.4f} | {gait.cost:.6f} ({gait.status}) | ")  # fmt: skip
    body_cot = ""
    if isinstance(verified, VerifiedGait) and not verified.failure:
        body_cot = f"{verified.positive_work / (vsw.weight * verified.step_length):.6f}"
    return (head + _verified_cells(verified, vsw.work)
            + f" | {vsw.work / (vsw.weight * vsw.step_length):.6f} | {body_cot} |")  # fmt: skip


def _grid_designs() -> list[tuple[float, float, GaitDesign]]:
    """Each cell's VSW biped: ``vsw design --model vsw-biped --target-speed V
    --target-step-length S --fix theta_II=0 --fix mu=0.1``, beta and b/l free, started at
    the nearest cell designed before it (cells in order of their distance from the
    defaults' gait; the first from the defaults), because the gaits at the defaults reach
    only the nearer cells."""
    biped = load("vsw_biped")
    home = _vsw_gait((), tuple(VSW_GAITS[0][1]))
    cells = sorted(
        ((v, s) for v in GRID_SPEEDS for s in GRID_STEPS),
        key=lambda c: (np.hypot(c[0] - home.speed, c[1] - home.step_length), c),
    )
    designed: list[tuple[float, float, GaitDesign]] = []
    for speed, step in cells:
        found = [(np.hypot(v - speed, s - step), d.parameters) for v, s, d in designed
                 if d.parameters is not None]  # fmt: skip
        nearest = min(found, key=lambda f: f[0])[1] if found else {}
        start = {k: v for k, v in nearest.items() if k not in GRID_FIXED}
        request = DesignRequest(targets={"speed": speed, "step_length": step},
                                fixed=GRID_FIXED, start=start)  # fmt: skip
        designed.append((speed, step, design(biped, request)))
    return sorted(designed, key=lambda c: (c[0], c[1]))


def _grid_row(speed: float, step: float, designed: GaitDesign) -> str:
    head = f"| {speed:g} | {step:g} | "
    if designed.status != "optimal" or designed.parameters is None:
        return head + f"none: {designed.message} |" + " |" * 10
    biped = load("vsw_biped")
    values = designed.parameters
    params = biped.parameters(values)
    totals = energy_ledger(biped, params, designed.orbit)["totals"]
    work = totals["actuator_work_impulsive"] + totals["actuator_work_continuous"]
    weight = walker_weight(biped, params)
    clearance = next(m["margin"] for m in designed.margins if m["name"] == "swing-foot-clearance")
    gait, verified = _body_gait(values, speed, step, starts=STARTS)
    body_cot = ""
    if isinstance(verified, VerifiedGait) and not verified.failure:
        body_cot = f"{verified.positive_work / (weight * verified.step_length):.6f}"
    return (head + f"{values['beta']:.4f}, {values['b_over_l']:.4f} | "
            f"{designed.orbit.max_abs_eigenvalue:.3g} | {clearance:.1e} | {work:.6f} | "
            f"{gait.cost:.6f} ({gait.status}) | " + _verified_cells(verified, work)
            + f" | {work / (weight * step):.6f} | {body_cot} |")  # fmt: skip


def _verified_cells(verified: VerifiedGait | str, vsw_work: float) -> str:
    if isinstance(verified, str):
        return f"none: {verified} | | | "
    if verified.failure:
        return f"none: {verified.failure} | | | "
    tangential, normal = verified.ground_impulses["heelstrike.new_foot"]
    ratio = vsw_work / verified.positive_work
    return (f"{verified.positive_work:.6f} ({verified.speed:.6f}, {verified.step_length:.6f}; "
            f"{verified.residual:.1e}) | {normal:.4f}, {tangential:.4f} | "
            f"{verified.stance_friction:.3f} | {ratio:.2f}")  # fmt: skip


def _stop_row(values: dict, guess: Sequence[float]) -> str:
    """The same with the end stop at l (free-vsw-biped-stop): gaits that extend the leg
    to its stop once a step, as VSW's."""
    vsw = _vsw_gait(tuple(values.items()), tuple(guess))
    gait, verified = _body_gait(values, vsw.speed, vsw.step_length, "free_vsw_biped_stop")
    cells = _verified_cells(verified, vsw.work)
    stop = ""
    if not isinstance(verified, str):
        tangential, normal = verified.ground_impulses.get("end_stop.stance_foot", (np.nan,) * 2)
        stop = f"{normal:.4f}, {tangential:.4f}"
    return f"| {vsw.label} | {gait.cost:.6f} ({gait.status}) | {cells} | {stop} |"


def _refinement_rows() -> list[str]:
    """The defaults' gait on each mesh of :data:`REFINEMENT`: least work, its re-simulated
    and verified work, the leg force's largest value and when."""
    vsw = _vsw_gait((), tuple(VSW_GAITS[0][1]))
    leg = input_names(load("free_vsw_biped"))["stance"].index("leg_force")
    rows = []
    for nodes in REFINEMENT:
        gait, verified = _body_gait({}, vsw.speed, vsw.step_length, nodes=nodes)
        force = gait.inputs[0][:, leg]
        peak = int(np.argmax(force))
        why = f": {gait.reason}" if gait.reason else ""
        rows.append(f"| {2 * nodes} | {gait.cost:.6f} ({gait.status}{why}) | "
                    f"{gait.extra['resimulated_work']:.6f} | {force[peak]:.3f} at "
                    f"{peak / (len(force) - 1):.4f} | " + _verified_cells(verified, vsw.work)
                    + " |\n")  # fmt: skip
    return rows


def _push_rows() -> list[str]:
    """The defaults' gait of the body with a push at a chosen angle (free-vsw-biped-push)
    from each of :data:`PUSH_STARTS`: the angle chosen, the push, the least work and its
    verification."""
    vsw = _vsw_gait((), tuple(VSW_GAITS[0][1]))
    names = [q.name for q in load("free_vsw_biped_push").parameter_table]
    angle = names.index("theta_push")
    rows = []
    for start in PUSH_STARTS:
        gait, verified = _body_gait({"theta_push": start}, vsw.speed, vsw.step_length,
                                    model="free_vsw_biped_push", nodes=10)  # fmt: skip
        why = f": {gait.reason}" if gait.reason else ""
        rows.append(f"| {start:g} | {gait.parameters[angle]:.4f} | "
                    f"{gait.impulses['push.push']:.2g} | "
                    f"{gait.cost:.6f} ({gait.status}{why}) | "
                    + _verified_cells(verified, vsw.work) + " |\n")  # fmt: skip
    return rows


def free_vsw_biped(out: Path, quick: bool = False) -> list[Path]:
    """Write ``out/free-vsw-biped.md`` (``quick``: the defaults' gait only, no end stop)."""
    cases = VSW_GAITS[:1] if quick else VSW_GAITS
    text = [
        "# VSW's price on its own biped\n\n",
        "Generated by `python -m paper_check.walkers --model free-vsw-biped` ",
        "(paper_check/vsw_price.py, whose docstring says how). Scaled units: lengths in l, ",
        "time in sqrt(l/g), energies in m_H g l; the body's leg between (beta - ",
        f"{STROKE_MARGIN:g}) l and l long: the VSW biped's stroke and {STROKE_MARGIN:g} l ",
        "more (a landing at the stroke's very end starts on the crouched failure's guard). ",
        "Each row: a VSW ",
        "biped gait (its parameters beside the defaults beta 0.8, theta_II 0, mu 0.1, ",
        "b/l 0.3), its actuators' work a step (the extension's) and the ground's impulse at ",
        "its extension (forward, up: friction ratios far above 1, or a pull), then the least ",
        "work found for the same body at the same speed and step (`vsw optimize --model ",
        f"free-vsw-biped --minimize work --friction {FRICTION:g} --clearance {CLEARANCE:g} ",
        f"--starts {STARTS}`, {2 * NODES} intervals; the best of the starts) on the mesh, ",
        "and verified (`--verify`: the work integrated ",
        "along the motion, its speed, step and the step's gap to periodic), the landing's ",
        "ground impulse (normal, tangential), the friction its stance needs (the largest ",
        "|tangential| / normal of the stance foot's reaction along it), and VSW's work over ",
        "the verified work: a lower bound on VSW's price, the verified gait being one gait ",
        "of the body; then each one's cost of transport (work over weight, (1 + 2 mu) m_H ",
        "g, times step length).\n\n",
        "| VSW gait | V | S | VSW work a step | VSW extension's ground impulse | body: least ",
        "work on the mesh | verified work (V, S; gap) | landing's ground impulse | stance ",
        "friction needed | VSW / verified | VSW's cost of transport | the verified gait's |\n",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
        *(_row(values, guess) + "\n" for values, guess in cases),
    ]
    if not quick:
        text += [
            "\n## With an end stop at l (`free-vsw-biped-stop`)\n\n",
            "The same body whose stance leg reaches an end stop at l once a step (the VSW ",
            "biped's extension, a push and a stop, is the limit of its motions): the least ",
            "work found among the gaits that extend the leg fully, as VSW's do. Stopping a ",
            "lengthening leg pulls its foot; that ground impulse is shown.\n\n",
            "| VSW gait | body with stop: least work on the mesh | verified work (V, S; gap) | ",
            "landing's ground impulse | stance friction needed | VSW / verified | stop's ground ",
            "impulse |\n",
            "| --- | --- | --- | --- | --- | --- | --- |\n",
            _stop_row(*VSW_GAITS[0]) + "\n",
            "\n## The defaults' gait as the mesh refines\n\n",
            "The first row's body gait optimised on finer meshes (`--nodes` 20, 40, 80), ",
            "each verified, with the leg force's largest value and when (the fraction of ",
            "the stance): where it grows as the mesh refines, the least work wants a leg ",
            "action faster than any mesh resolves.\n\n",
            "| intervals | least work on the mesh | along the re-simulated step | largest leg ",
            "force | verified work (V, S; gap) | landing's ground impulse | stance friction ",
            "needed | VSW / verified |\n",
            "| --- | --- | --- | --- | --- | --- | --- | --- |\n",
            *_refinement_rows(),
            "\n## With a push at a chosen angle (`free-vsw-biped-push`)\n\n",
            "The same body whose stance is split where the stance leg passes `theta_push`, an ",
            "angle the optimiser chooses with the gait, where the leg may push along itself ",
            "and the hip act in an instant (with both zero, the free body's stance): the ",
            "defaults' gait from several starts of the angle, 20 intervals a phase.\n\n",
            "| start | theta_push chosen | push | least work on the mesh | verified work (V, S; ",
            "gap) | landing's ground impulse | stance friction needed | VSW / verified |\n",
            "| --- | --- | --- | --- | --- | --- | --- | --- |\n",
            *_push_rows(),
            "\n## A grid of speeds and step lengths\n\n",
            "At a fixed body the VSW biped's two gait parameters move its speed and step ",
            "length almost along one line, so a grid of both needs the body's own proportions ",
            "free: at each cell a VSW biped designed to walk there (`vsw design --model ",
            "vsw-biped --target-speed V --target-step-length S --fix theta_II=0 --fix mu=0.1`: ",
            "its beta and b/l; each cell started at the nearest cell designed before it), its ",
            "gait's largest |eigenvalue| and swing-foot clearance (negative: it scuffs, which ",
            "the VSW biped ignores and the body's gaits may not), its work a step, and the ",
            "least work found for the same body at the same speed and step, as above.\n\n",
            "| V | S | robot: beta, b/l | VSW max abs eigenvalue | VSW swing-foot clearance | ",
            "VSW work a step | body: least work on the mesh | verified work (V, S; gap) | ",
            "landing's ground impulse | stance friction needed | VSW / verified | VSW's cost ",
            "of transport | the verified gait's |\n",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
            *(_grid_row(*cell) + "\n" for cell in _grid_designs()),
        ]
    path = out / "free-vsw-biped.md"
    path.write_text("".join(text))
    return [path]
