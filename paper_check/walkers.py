"""``python -m paper_check.walkers [--model NAME ...] [--out DIR]`` (also
``python -m paper_check --model NAME``): the walkers with massive legs beside what their
sources publish.

For each model a short Markdown report ``DIR/<model>.md`` and its figures:

* ``simplest-walker``: Garcia et al. (1998) and the code behind it, Bhounsule's code: the
  two gaits at gamma = 0.009, their step periods and eigenvalues (ours and, as the
  independent check, central differences of the simulated map), the slope where the long
  gait loses stability, the small-slope expansions of Garcia's Table 1 fitted to our gaits,
  and the bifurcation diagram (continuation, then the map iterated);
* ``compass-gait``: Goswami, Thuilot & Espiau (1996) at 3 degrees, the first period
  doubling, Drake's default parameters, and the bifurcation diagram against the slope;
* ``vsw-biped``: the paper's own next step, the leg-mass study (mu from 1e-4 to 1 at two
  (beta, theta_II)) with its figure;
* ``kneed-walker``: Hsu Chen (2007)'s point-foot kneed walker (McGeer 1990's model): her
  gait's state and period, an independent re-implementation's gait and eigenvalues, and
  where the map from her published state goes;
* ``kuo-walker``: Kuo's ratio, the push-off against the stance
  torque at one speed and step length, beside its derivation (:mod:`paper_check.kuo`);
* ``point-mass-biped``: its least-work gaits (``vsw optimize``) beside Srinivasan & Ruina
  (2006)'s inverted-pendulum walking with its cost derived in :mod:`paper_check.powered`,
  and the ILE's price against the least work of its own body;
* ``free-vsw-biped``: the VSW biped's gaits against the least work found for the same
  body at their speeds and step lengths, verified (:mod:`paper_check.vsw_price`).

Each row of a comparison says the published value, its source, ours, the difference, the
tolerance the source's precision allows and a verdict: ``agrees`` within it, ``differs``
beyond it (with what we found about why). Sources not at hand in the original (quoted by
others) say so. Everything written is deterministic (no timings in the files).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

import generated.ile as ile
from paper_check.kuo import kuo_walker
from paper_check.output import check_output_directory
from paper_check.powered import point_mass_biped
from paper_check.rows import Row
from paper_check.rows import table as _table
from paper_check.vsw_price import free_vsw_biped
from vsw.dynamics.conditions import gait_conditions
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.ledger import energy_ledger
from vsw.gaits.continuation import Options, SpecialPoint, continue_gaits
from vsw.models import load
from vsw.plots import plotstyle
from vsw.plots.diagrams import bifurcation_plot, diagram_quantity, diagram_units
from vsw.plots.figures import save_figure
from vsw.runtime.errors import ConvergenceError
from vsw.runtime.jsonable import clean
from vsw.studies.grid_basin import basin_plot, grid_basin
from vsw.studies.sweeps import brute_force, continuation, record

MODELS = ("simplest-walker", "compass-gait", "vsw-biped", "kneed-walker", "point-mass-biped",
          "kuo-walker", "free-vsw-biped")  # fmt: skip

SOURCES = {
    "G98": "Garcia, Chatterjee, Ruina, Coleman, The simplest walking model: stability, "
    "complexity, and scaling, J. Biomech. Eng. 120(2):281-288, 1998 (abstract)",
    "G98code": "Garcia's code for G98 (pointfoot.m / run_doubpend.m, 1998), comments "
    "'gam=0.009 long step to 1e-10' and '... short step to 1e-10'",
    "G98T1": "G98 Table 1 (Appendix A.2) as quoted by the public repository nyasuto/crane "
    "(src/crane/references.py); the table itself was not at hand",
    "G98sec": "G98 sections 5.1-5.3 as quoted by nyasuto/crane: stable period-one gaits for "
    "0 < gamma < 0.0151",
    "B13": "Bhounsule's code simplestwalker.m (github.com/pab47, 25 August 2013), comments "
    "at gamma = 0.009",
    "HC07": "V. F. Hsu Chen, Passive dynamic walking with knees: a point foot model, MEng "
    "thesis, MIT, 2007, chapter 3 (its limit cycle at gamma = 0.0504 rad), as quoted by "
    "nyasuto/crane (README, 'Phase 3'); the thesis itself was not at hand",
    "NC26": "nyasuto/crane (github), README 'Phase 3': an independent Python re-implementation "
    "of HC07's model (its own sympy derivation and Newton shooting, residual 5e-14)",
    "GTE96": "Goswami, Thuilot, Espiau, Compass-like biped robot part I, INRIA RR-2996, "
    "1996, as quoted by nyasuto/crane (src/crane/references_goswami.py): values read off "
    "its figures C.4/C.5 (+-2 %) and its eq. (3.44)",
}


def _vector(orbit: Orbit) -> np.ndarray:
    return np.array(list(orbit.state.values()))


def _continue(m: HybridModel, values: dict, name: str, targets, orbit: Orbit,
              failures: dict | None = None) -> list:  # fmt: skip
    """(value, orbit or None, params) along ``targets`` of parameter ``name``, each orbit
    from the previous one; stops at the first that does not converge (its reason into
    ``failures`` under its value)."""
    out = []
    for value in targets:
        params = m.parameters({**values, name: float(value)})
        try:
            orbit = m.periodic_orbit(params, _vector(orbit), orbit.durations)
        except ConvergenceError as exc:
            out.append((value, None, params))
            if failures is not None:
                failures[value] = str(exc).split(": ", 1)[-1]
            break
        out.append((value, orbit, params))
    return out


def _reached(walked: list) -> Orbit:
    """The last orbit of a continuation that must have reached its end."""
    value, orbit, _ = walked[-1]
    if orbit is None:
        raise ConvergenceError(f"the gait was lost at {value:g} on the way")
    return orbit


def _flips(m: HybridModel, values: dict, name: str, start: float, stop_value: float,
           orbit: Orbit, max_period: int) -> list[tuple[int, float]]:  # fmt: skip
    """The flips located by continuation (:mod:`vsw.gaits.continuation`) of ``orbit`` from
    ``start`` to ``stop_value`` and of the period-doubled gaits born at them, up to
    ``max_period``: (period of the gait that flips, parameter), in order."""
    options = Options(switch=max_period > 1, max_period=max_period)
    params = m.parameters({**values, name: start})
    branches = continue_gaits(m, params, name, start, stop_value, _vector(orbit),
                              orbit.durations, options=options)  # fmt: skip
    found = [(b.period, s.parameter) for b in branches for s in b.special_points
             if s.type == "flip"]  # fmt: skip
    return sorted(found, key=lambda f: f[1])


def _branch_end(m: HybridModel, values: dict, name: str, start: float, stop_value: float,
                orbit: Orbit) -> SpecialPoint | None:  # fmt: skip
    """Where the gait continued from ``start`` ends before ``stop_value`` (a boundary
    located by continuation), or None."""
    params = m.parameters({**values, name: start})
    (branch,) = continue_gaits(m, params, name, start, stop_value, _vector(orbit),
                               orbit.durations, options=Options(switch=False))  # fmt: skip
    ends = [s for s in branch.special_points if s.type == "boundary"]
    return ends[-1] if branch.ended == "boundary" and ends else None


def _central_difference_eigenvalues(m: HybridModel, params, x: np.ndarray, h: float = 1e-6):
    """Eigenvalues of the simulated map's Jacobian by central differences of whole steps
    (SciPy DOP853 with event location: no CasADi, no derivative of the integration)."""
    jac = np.zeros((len(x), len(x)))
    for k in range(len(x)):
        e = np.zeros(len(x))
        e[k] = h
        jac[:, k] = (m.step(params, x + e).state - m.step(params, x - e).state) / (2 * h)
    return sorted(np.linalg.eigvals(jac), key=lambda v: (-abs(v), v.imag))


def _diagram(
    model: str, over: str, grid: tuple[float, float, int], keep: int, transient: int,
    out: Path, stem: str, y: str,
) -> tuple[dict, list]:  # fmt: skip
    """The bifurcation diagram as ``vsw sweep --plot`` draws it (:func:`vsw.studies.sweeps.
    continuation`), as PNG and SVG, and its record."""
    m = load(model)
    start, stop, count = grid
    points = continuation(m, {}, over, np.linspace(start, stop, count), keep, transient)
    data = clean(record(m, {}, over, points, keep, transient))
    written = []
    for suffix in ("png", "svg"):
        path = out / f"{stem}.{suffix}"
        title = plotstyle.parameter_text(m, data["parameters"])
        figure = bifurcation_plot(data, diagram_quantity(m, y), diagram_units(m.units), title)
        save_figure(figure, path)
        written.append(path)
    return data, written


def _minus_x(basin: dict) -> dict:
    """A basin record over x drawn over -x (the sources' sign of an angle): the columns
    reversed, so that -x increases to the right."""
    name = basin["x_name"]
    return {
        **basin,
        "x_name": f"-{name}",
        "x": [-v for v in reversed(basin["x"])],
        "outcome": [list(reversed(row)) for row in basin["outcome"]],
        "steps": [list(reversed(row)) for row in basin["steps"]],
        "fixed_point": {**basin["fixed_point"], f"-{name}": -basin["fixed_point"][name]},
    }


def _basin_section(out: Path, quick: bool) -> tuple[list[str], list[Path]]:
    """The simplest walker's basin over theta x theta_dot just after heelstrike and the
    brute-force bifurcation diagram, both through the command line (batch simulator)."""
    side = 60 if quick else 500
    png = out / "simplest-walker_basin.png"
    m = load("simplest_walker")
    params = m.parameters({})
    found = grid_basin(m, params, "theta", np.linspace(-0.36, -0.1, side), "theta_dot",
                       np.linspace(0.1, 0.4, side), 50)  # fmt: skip
    basin = clean({**found.to_dict(), "model": m.cli_name})
    units = {s["name"]: s["unit"] for s in m.spec["state"]}
    # Drawn in the sources' sign of the stance angle, as the bifurcation diagrams here.
    shown = _minus_x(basin)
    save_figure(basin_plot(shown, units, plotstyle.parameter_text(m, params)), png)
    counts = basin["counts"]
    cells = side * side
    steps = np.array(basin["steps"])
    converged = np.array([[c == "converged" for c in row] for row in basin["outcome"]])
    count, transient, keep = (6, 100, 16) if quick else (85, 300, 64)
    diagram_png = out / "simplest-walker_brute-force.png"
    points = brute_force(m, {}, "gamma", np.linspace(0.009, 0.0195, count), transient, keep)
    diagram = clean(record(m, {}, "gamma", points, keep, transient, "brute-force"))
    title = plotstyle.parameter_text(m, diagram["parameters"])
    save_figure(bifurcation_plot(diagram, "-theta", diagram_units(m.units), title), diagram_png)
    periods = []
    for p in diagram["points"]:
        a = p["attractor"]
        kind = a["ended"] if a["ended"] != "completed" else (
            f"period-{a['period']}" if a["period"] else "no repeat")  # fmt: skip
        if not periods or periods[-1][1] != kind:
            periods.append((p["gamma"], kind))
    first = ", ".join(f"{kind} from {g:.6g}" for g, kind in periods)
    text = [
        "\n## Basin of attraction (batch simulator)\n\n",
        f"![basin]({png.name})\n\n",
        f"`vsw basin --model simplest-walker --grid theta=-0.36:-0.1:{side} --grid ",
        f"theta_dot=0.1:0.4:{side}` at gamma = 0.009: the cells are section states just after ",
        "heelstrike (phi = 2 theta and the swing rate the impact gives, from the model's ",
        "section), walked up to 50 steps; drawn over minus theta, the sources' sign of the ",
        "stance angle, as the bifurcation diagrams of this report. ",
        ", ".join(f"{label}: {n} cells ({100 * n / cells:.2f} %)" for label, n in counts.items()),
        f"; converged cells took {int(steps[converged].min())} to "
        f"{int(steps[converged].max())} steps to come within 1e-6 of the gait. The basin is a ",
        'thin band through the stable gait. Schwab and Wisse (2001, "Basin of attraction ',
        'of the simplest walking model", Proc. ASME DETC) computed it by cell mapping and ',
        "found it small and thin; their figure ",
        "was not at hand, so no number of theirs is compared here.\n\n",
        "## Bifurcation diagram by brute force\n\n",
        f"![brute-force diagram]({diagram_png.name})\n\n",
        f"`vsw sweep --model simplest-walker --over gamma=0.009:0.0195:{count} --brute-force`: ",
        "at every slope the gait by Newton on the batch-simulated map, then the map iterated ",
        f"{diagram['transient']} steps from it (moved by 1e-6) and the last {diagram['keep']} ",
        f"kept, in one batch. What the iterated map does along gamma: {first}. Near each ",
        "flip the transient is too short for the walk to settle, so a doubling shows up a ",
        "little later here than in the continuation's diagram above.\n",
    ]
    return text, [png, diagram_png]


def _diagram_table(data: dict) -> str:
    over = data["over"]
    unit = f" ({data['over_unit']})" if data.get("over_unit") else ""
    degrees = data.get("over_unit") == "rad"
    lines = [f"| {over}{unit} |" + (" (deg) |" if degrees else "")
             + " period-one gait | max abs eigenvalue | iterated map |",
             "| --- | --- | --- | --- |" + (" --- |" if degrees else "")]  # fmt: skip
    for p in data["points"]:
        a = p.get("attractor")
        if a is None:
            walk = "(the stable gait)" if p["stable"] else ""
        elif a["ended"] != "completed":
            walk = f"fell ({a['ended']}) after {a['steps_walked']} steps"
        else:
            walk = f"period-{a['period']}" if a["period"] else (
                f"no repeat in the last {len(a['states'])} steps")  # fmt: skip
        eig = "" if p["max_abs_eigenvalue"] is None else f"{p['max_abs_eigenvalue']:.4f}"
        gait = "none found" if not p["found"] else ("stable" if p["stable"] else "unstable")
        shown = f"| {p[over]:.6g} |" + (f" {math.degrees(p[over]):.4g} |" if degrees else "")
        lines.append(f"{shown} {gait} | {eig} | {walk} |")
    return "\n".join(lines) + "\n"


def _write_report(path: Path, parts: Sequence[str], figures: Sequence[Path]) -> list[Path]:
    path.write_text("".join(parts))
    return [path, *figures]


def _sources(keys: Sequence[str]) -> str:
    return "Sources:\n\n" + "".join(f"* [{k}] {SOURCES[k]}\n" for k in keys) + "\n"


# --- the simplest walker -------------------------------------------------------------------

GARCIA_LONG = (0.20031090049483, -0.19983247291764)  # [G98code], theta1, theta1dot
GARCIA_SHORT = (0.19393736960624, -0.20386692731962)
GARCIA_LONG_EIGENVALUE = complex(-0.19120868949940, 0.55633363687106)  # [G98code]
GARCIA_SHORT_EIGENVALUES = (4.000, 0.459)  # [G98code]
BHOUNSULE_LONG = ((0.200310900563820, -0.199832473025474, 0.400621801127640,
                   -0.015822999949030), 3.882)  # [B13] (q1, u1, q2, u2), t  # fmt: skip
BHOUNSULE_SHORT = ((0.193937369810188, -0.203866927442012, 0.387874739620375,
                    -0.015144260853193), 3.096)  # fmt: skip
TABLE1 = {  # [G98T1]: Theta0, Theta1, tau0, tau1
    "long": (0.970956, -0.270837, 3.812092, 1.579129),
    "short": (0.943976, -0.264561, math.pi, -0.907496),
}


def _expansion_fits(m: HybridModel, orbit: Orbit) -> tuple[np.ndarray, np.ndarray]:
    """(Theta0, Theta1, tau0, tau1) fitted with three and with four terms in powers of
    gamma^(2/3) to the gait continued from 0.009 to 5e-6 (fit on gamma <= 1e-4); their
    difference is the fit's uncertainty."""
    gammas = np.geomspace(0.009, 5e-6, 45)
    walked = _continue(m, {}, "gamma", gammas, orbit)
    _reached(walked)
    orbits = [o for _, o, _ in walked]
    ratio = np.array([-o.state["theta"] for o in orbits]) / gammas ** (1 / 3)
    period = np.array([o.period for o in orbits])
    small = gammas <= 1e-4
    fits = []
    for terms in (3, 4):
        basis = np.vstack([gammas[small] ** (2 * j / 3) for j in range(terms)]).T
        theta = np.linalg.lstsq(basis, ratio[small], rcond=None)[0]
        tau = np.linalg.lstsq(basis, period[small], rcond=None)[0]
        fits.append(np.array([theta[0], theta[1], tau[0], tau[1]]))
    return fits[0], np.abs(fits[1] - fits[0])


def simplest_walker(out: Path, quick: bool = False) -> list[Path]:
    m = load("simplest_walker")
    params = m.parameters({"gamma": 0.009})
    # Garcia's two gaits are the shortest steps; the search of the section (vsw.gaits.search) also
    # finds gaits whose swing leg swings back and forth before heelstrike.
    found = sorted(m.fixed_points(params), key=lambda o: o.period)
    short, long = found[0], found[1]
    others = found[2:]
    rows: list[Row] = []
    for name, orbit, (theta, theta_dot) in (("long", long, GARCIA_LONG),
                                            ("short", short, GARCIA_SHORT)):  # fmt: skip
        rows.append(Row(f"{name} gait theta (rad)", "G98code", theta, -orbit.state["theta"], 5e-10,
                        "the source's tolerance 1e-10"))  # fmt: skip
        rows.append(Row(f"{name} gait theta_dot", "G98code", theta_dot, -orbit.state["theta_dot"],
                        5e-10, "the source's tolerance 1e-10"))  # fmt: skip
    for name, orbit, (state, step_time) in (("long", long, BHOUNSULE_LONG),
                                            ("short", short, BHOUNSULE_SHORT)):  # fmt: skip
        s = orbit.state
        ours = (-s["theta"], -s["theta_dot"], -s["phi"], -s["phi_dot"])
        for label, a, b in zip(("theta", "theta_dot", "phi", "phi_dot"), state, ours):
            rows.append(Row(f"{name} gait {label}", "B13", a, b, 1e-10, "15 digits printed"))
        rows.append(Row(f"{name} gait step period", "B13", step_time, orbit.period, 5e-4,
                        "3 decimals printed"))  # fmt: skip
    fd_long = _central_difference_eigenvalues(m, params, _vector(long))
    fd_short = _central_difference_eigenvalues(m, params, _vector(short))
    lam = max(long.eigenvalues[:2], key=lambda v: v.imag)
    fd = max(fd_long[:2], key=lambda v: v.imag)
    why = ("ours equal central differences of the simulated map to {gap:.1g} (DOP853, "
           "step 1e-6); the source is off by the difference shown, its method not "
           "stated")  # fmt: skip
    published = GARCIA_LONG_EIGENVALUE
    for part, a, b, c in (("real", published.real, lam.real, fd.real),
                          ("imaginary", published.imag, lam.imag, fd.imag)):  # fmt: skip
        rows.append(Row(f"long gait eigenvalue, {part} part", "G98code", a, b, 5e-15,
                        why.format(gap=abs(b - c))))  # fmt: skip
    for k, published in enumerate(GARCIA_SHORT_EIGENVALUES):
        ours, check = short.eigenvalues[k].real, fd_short[k].real
        rows.append(Row(f"short gait eigenvalue {k + 1}", "G98code", published, ours, 5e-4,
                        why.format(gap=abs(ours - check))))  # fmt: skip
    # Loss of stability: the long gait's first flip, located by continuation (vsw continue).
    cascade = _flips(m, {}, "gamma", 0.009, 0.0183, long, max_period=4)
    limit = cascade[0][1]
    rows.append(Row("long gait stable up to gamma", "G98", 0.015, limit, 5e-4, "2 digits"))
    rows.append(Row("long gait stable up to gamma", "G98sec", 0.0151, limit, 5e-5, "3 digits"))
    for name, orbit in (("long", long), ("short", short)):
        fit, uncertainty = _expansion_fits(m, orbit)
        for k, label in enumerate(("Theta0", "Theta1", "tau0", "tau1")):
            published = TABLE1[name][k]
            tol = max(5e-7, 2 * uncertainty[k])
            note = f"fit uncertainty {uncertainty[k]:.1g}"
            if name == "long" and label == "Theta1":
                g98 = GARCIA_LONG[0]
                t0 = TABLE1["long"][0] * 0.009 ** (1 / 3)
                with_ours = abs(t0 + fit[1] * 0.009 - g98)
                with_quote = abs(t0 + published * 0.009 - g98)
                note += (f"; at gamma = 0.009 the two-term expansion is {with_ours:.1g} from "
                         f"G98code's theta with ours, {with_quote:.1g} with the quoted value: "
                         "the quote (or the table) is off")  # fmt: skip
            rows.append(Row(f"{name} gait {label}", "G98T1", published, fit[k], tol, note))
    count, keep, transient = (6, 16, 150) if quick else (43, 64, 300)
    start = 0.0145 if quick else 0.009
    data, written = _diagram("simplest-walker", "gamma", (start, 0.0195, count), keep,
                             transient, out, "simplest-walker_bifurcation",
                             "-theta")  # fmt: skip
    text = [
        "# The simplest walking model beside its sources\n\n",
        "Generated by `python -m paper_check.walkers --model simplest-walker`. The engine's ",
        "angles are minus those of the sources (its theta is positive with the hip downhill ",
        "of the stance foot); the rows compare the sources' signs.\n\n",
        _sources(["G98", "G98code", "G98T1", "G98sec", "B13"]),
        "## Gaits, periods, eigenvalues, stability, small-slope expansions\n\n",
        _table(rows),
        "\nBeside the sources' two, the search of the section (`vsw analyze --model "
        f"simplest-walker --param gamma=0.009`) finds {len(others)} more period-one "
        "gait(s), none of them in the sources: "
        + "; ".join(
            f"period {o.period:.4f}, stance angle {-o.state['theta']:.6f} rad, max "
            f"abs eigenvalue {o.max_abs_eigenvalue:.4g}"
            for o in others
        )
        + " (the swing leg swings back and forth before heelstrike; all unstable).\n",
        "\n## Bifurcation diagram\n\n",
        f"![bifurcation diagram]({written[0].name})\n\n",
        "The stance angle at heelstrike (G98's sign: minus the engine's theta) of the long ",
        "gait continued along gamma; past its loss of stability the map is iterated ",
        f"{transient} steps from the previous point's state and the last {keep} are kept. ",
        'G98 (abstract): "with increasing gamma, stable cycles of higher periods appear, and ',
        "the walking-like motions apparently become chaotic through a sequence of period ",
        'doublings"; as quoted in J. NeuroEng. Rehabil. 4:30 (2007), Fig. 1 caption: ',
        "chaotic between 0.01839 and 0.0189 rad, no stable gaits above 0.019 rad.\n\n",
        _diagram_table(data),
    ]
    basin_text, basin_figures = _basin_section(out, quick)
    return _write_report(out / "simplest-walker.md", text + basin_text,
                         [*written, *basin_figures])  # fmt: skip


# --- the compass gait ----------------------------------------------------------------------


def compass_gait(out: Path, quick: bool = False) -> list[Path]:
    m = load("compass_gait")
    three = math.radians(3.0)
    (orbit,) = [o for o in m.fixed_points(m.parameters({"gamma": three})) if o.stable]
    moduli = sorted((abs(e) ** 2 for e in orbit.eigenvalues), reverse=True)
    figure = "read off a figure (+-2 %)"
    rows = [
        Row("half inter-leg angle at heelstrike, 3 deg (rad)", "GTE96", 0.271,
            -orbit.state["theta"], 0.02 * 0.271, figure),
        Row("step period, 3 deg (s)", "GTE96", 0.735, orbit.period, 0.02 * 0.735, figure),
        Row("stride-map eigenvalue modulus 1, 3 deg", "GTE96", 0.332, moduli[0], 5e-4,
            "eq. (3.44); ours: the step map's squared (a symmetric gait)"),
        Row("stride-map eigenvalue modulus 2, 3 deg", "GTE96", 0.332, moduli[1], 5e-4,
            "the complex pair"),
        Row("stride-map eigenvalue modulus 3, 3 deg", "GTE96", 0.014, moduli[2], 5e-4,
            "the smallest; the source's method is not known to us"),
    ]  # fmt: skip
    flips = _flips(m, {}, "gamma", three, math.radians(5.1), orbit, max_period=4)
    located = "ours located by continuation (vsw continue): an eigenvalue at -1 to 1e-9"
    for (period, flip), (label, quoted, tolerance, digits) in zip(flips, (
        ("first", 4.37, 5e-3, "the source's slope grid is not known"),
        ("second", 4.9, 0.05, "2 digits as quoted"),
        ("third", 5.01, 5e-3, "3 digits as quoted"),
    )):  # fmt: skip
        rows.append(Row(f"{label} period doubling (deg)", "GTE96", quoted,
                        math.degrees(flip), tolerance,
                        f"{located}, on the period-{period} gait; {digits}"))  # fmt: skip
    defaults = m.fixed_points(m.parameters({}))
    gaits = ["| gait | theta (rad) | psi (rad) | theta_dot (1/s) | psi_dot (1/s) | period (s) "
             "| max abs eigenvalue | stable |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for k, o in enumerate(defaults, 1):
        s = o.state
        gaits.append(f"| {k} | {s['theta']:.10f} | {s['psi']:.10f} | {s['theta_dot']:.10f} | "
                     f"{s['psi_dot']:.10f} | {o.period:.10f} | {o.max_abs_eigenvalue:.6f} | "
                     f"{'yes' if o.stable else 'no'} |")  # fmt: skip
    count, keep, transient = (5, 16, 150) if quick else (49, 64, 300)
    start = 4.2 if quick else 3.0
    data, written = _diagram("compass-gait", "gamma",
                             (math.radians(start), math.radians(5.4), count), keep, transient,
                             out, "compass-gait_bifurcation", "-theta")  # fmt: skip
    text = [
        "# The compass gait beside its sources\n\n",
        "Generated by `python -m paper_check.walkers --model compass-gait`. Parameters: ",
        "Drake's defaults (m_h = 10 kg, m = 5 kg, a = b = 0.5 m, g = 9.81 m/s^2), which are ",
        "GTE96's standard case; slopes as stated.\n\n",
        _sources(["GTE96"]),
        "## At 3 degrees, and the first period doubling\n\n",
        _table(rows),
        "\n## Drake's default slope (0.0525 rad)\n\n",
        "Drake's tests check energy in swing and momentum across the impact, not a fixed ",
        "point: these are ours, for the record.\n\n",
        "\n".join(gaits) + "\n",
        "\n## Bifurcation diagram against the slope\n\n",
        f"![bifurcation diagram]({written[0].name})\n\n",
        "The half inter-leg angle at heelstrike (minus the engine's theta) against the slope. ",
        f"GTE96 as quoted: period doublings at 4.37, 4.9 and 5.01 degrees, chaos at 5.2. Ours "
        f"(the map iterated {transient} steps, last {keep} kept; our walks stop where the ",
        "stance foot would be pulled off the ground, lift-off, a failure the quoted analysis ",
        "may not check):\n\n",
        _diagram_table(data),
    ]
    return _write_report(out / "compass-gait.md", text, written)


# --- the compass-like VSW biped ------------------------------------------------------------

STUDY = ((0.8, 0.1), (0.85, 0.05), (0.97, -0.2))
"""(beta, theta_II) of the leg-mass study (b / l = 0.3): two where every gait is unstable,
and one of the stable gaits the search (:data:`SEARCH`) finds near beta = 1."""
SEARCH = {"beta": (0.8, 0.9, 0.95, 0.97, 0.99), "theta_II": (-0.2, -0.1, 0.0, 0.1), "mu": 0.3}
"""The grid of the stable-gait search (b / l = 0.3)."""


def _mu_rows(m: HybridModel, beta: float, theta_II: float, failures: dict) -> list[tuple]:
    """The least unstable gait found at mu = 0.01, continued down to 1e-4 and up to 1."""
    values = {"beta": beta, "theta_II": theta_II}
    orbits = m.fixed_points(m.parameters({**values, "mu": 1e-2}))
    first = min(orbits, key=lambda o: o.max_abs_eigenvalue)
    down = _continue(m, values, "mu", [1e-2, 1e-3, 1e-4], first, failures)
    up = _continue(m, values, "mu", [0.03, 0.1, 0.3, 0.5, 1.0], first, failures)
    return sorted(down + up, key=lambda r: r[0])


def _stable_search(m: HybridModel) -> str:
    """Every gait the scan finds on the :data:`SEARCH` grid: how many, the least unstable,
    whether a walk from it with every rate 1 % off comes back (simulated, 60 steps), its
    swing foot's clearance (negative: it scuffs, which the model ignores) and the work of
    the extension per step (the energy ledger: what heelstrike dissipates on a gait)."""
    lines = ["| beta | theta_II | gaits found | least max abs eigenvalue | walk from 1 % off "
             "(60 steps) | swing-foot clearance (l) | extension work (m_H g l) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for beta in SEARCH["beta"]:
        for theta_II in SEARCH["theta_II"]:
            params = m.parameters({"beta": beta, "theta_II": theta_II, "mu": SEARCH["mu"]})
            orbits = m.fixed_points(params)
            if not orbits:
                lines.append(f"| {beta} | {theta_II} | 0 | | | | |")
                continue
            best = min(orbits, key=lambda o: o.max_abs_eigenvalue)
            x = _vector(best)
            start = np.concatenate([x[: m.n], 1.01 * x[m.n :]])
            walk = m.simulate(params, start, 60)
            if walk.ended != "completed":
                count = walk.steps_completed
                outcome = f"{walk.ended} after {count} step{'' if count == 1 else 's'}"
            else:
                gap = float(np.max(np.abs(walk.section[-1] - x)))
                outcome = f"{gap:.1g} from the gait"
            (clearance,) = [c["margin"] for c in gait_conditions(m, params, best)
                            if c["name"] == "swing-foot-clearance"]  # fmt: skip
            (extension,) = [e for e in energy_ledger(m, params, best)["events"]
                            if e["event"] == "extension"]  # fmt: skip
            lines.append(f"| {beta} | {theta_II} | {len(orbits)} | "
                         f"{best.max_abs_eigenvalue:.4g} | {outcome} | {clearance:.2g} | "
                         f"{extension['actuator_work']:.5f} |")  # fmt: skip
    return "\n".join(lines) + "\n"


REGION = {"beta": (0.9, 0.95, 0.97, 0.99), "theta_II": (-0.2, -0.1, 0.0, 0.1),
          "mu": (0.01, 0.1, 0.3)}  # fmt: skip
"""The grid of the stable region under each extension rule (b / l = 0.3)."""
RULES = (("vsw_biped", "held hip", {}), ("vsw_biped_fte", "free hip, delta = 0.3", {"delta": 0.3}))
"""The models compared on :data:`REGION`: the instantaneous extension with the held-hip
rule, and the free hip with the extension over 0.3 rad of stance angle."""


def stable_region(model_name: str, fixed: dict) -> dict[tuple[float, float, float], float | None]:
    """The least max |eigenvalue| of the gaits the search finds at each cell of
    :data:`REGION` (None where it finds none)."""
    m = load(model_name)
    out = {}
    for mu in REGION["mu"]:
        for beta in REGION["beta"]:
            for theta_II in REGION["theta_II"]:
                values = {"beta": beta, "theta_II": theta_II, "mu": mu, **fixed}
                orbits = m.fixed_points(m.parameters(values))
                out[beta, theta_II, mu] = min((o.max_abs_eigenvalue for o in orbits), default=None)
    return out


def _region_table(regions: dict[str, dict]) -> str:
    """One row per (mu, beta), one column per theta_II: each rule's least max |eigenvalue|
    (stable below 1, in bold)."""
    head = " | ".join(f"theta_II = {t}" for t in REGION["theta_II"])
    lines = [f"| mu | beta | {head} |", "| --- | --- |" + " --- |" * len(REGION["theta_II"])]

    def cell(value: float | None) -> str:
        if value is None:
            return "none"
        return f"**{value:.3g}**" if value < 1 else f"{value:.3g}"

    for mu in REGION["mu"]:
        for beta in REGION["beta"]:
            cells = [" / ".join(cell(regions[label][beta, t, mu]) for _, label, _ in RULES)
                     for t in REGION["theta_II"]]  # fmt: skip
            lines.append(f"| {mu} | {beta} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


SWEEP = {"cells": ((0.97, -0.2), (0.97, 0.0), (0.99, -0.1)), "mu": 0.3,
         "b_over_l": (0.02, 0.3, 0.9), "switch": (0.97, -0.2)}  # fmt: skip
"""The stable gaits whose band of b / l the report locates: continued from b / l = 0.3 down
to 0.02 and up to 0.9, following the period-doubled branches for ``switch`` (upwards)."""
BASINS = {"cells": ((0.97, -0.2), (0.97, 0.0), (0.99, -0.1), (0.99, 0.0)), "mu": 0.3,
          "theta_dot": (0.0, 1.5, 301), "psi_dot": (-3.0, 3.0, 301), "steps": 50}  # fmt: skip
"""The basins of the stable gaits: (theta_dot, psi_dot) slices of the section at the gait's
stance angle, walked by the batch simulator."""


def _least_unstable(m: HybridModel, values: dict) -> tuple[np.ndarray, Orbit]:
    params = m.parameters(values)
    return params, min(m.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)


def _b_sweep(m: HybridModel) -> str:
    """Every branch continuation finds from each :data:`SWEEP` gait along b / l, with its
    located special points."""
    low, start, high = SWEEP["b_over_l"]
    lines = ["| beta | theta_II | period | b / l from | to | ended | special points (b / l) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for beta, theta_II in SWEEP["cells"]:
        values = {"beta": beta, "theta_II": theta_II, "mu": SWEEP["mu"], "b_over_l": start}
        params, orbit = _least_unstable(m, values)
        for stop in (low, high):
            switch = stop == high and (beta, theta_II) == SWEEP["switch"]
            branches = continue_gaits(m, params, "b_over_l", start, stop, _vector(orbit),
                                      orbit.durations, options=Options(switch=switch))  # fmt: skip
            for branch in branches:
                ends = [p["parameter"] for p in branch.points]
                points = "; ".join(
                    f"{s.type} {s.parameter:.7f}" + (f" ({s.condition})" if s.condition else "")
                    for s in branch.special_points
                )
                lines.append(f"| {beta} | {theta_II} | {branch.period} | {ends[0]:.5f} | "
                             f"{ends[-1]:.5f} | {branch.ended} | {points} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def _basins(m: HybridModel) -> str:
    """Each :data:`BASINS` gait's basin: how many starts converge, the area they cover and
    how the others end."""
    (x0, x1, nx), (y0, y1, ny) = BASINS["theta_dot"], BASINS["psi_dot"]
    x, y = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)
    cell = (x[1] - x[0]) * (y[1] - y[0])
    lines = ["| beta | theta_II | max abs eigenvalue | converged cells | area (rad^2 / (l/g)) "
             "| ended by (cells) |", "| --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for beta, theta_II in BASINS["cells"]:
        params, orbit = _least_unstable(m, {"beta": beta, "theta_II": theta_II,
                                            "mu": BASINS["mu"]})  # fmt: skip
        basin = grid_basin(m, params, "theta_dot", x, "psi_dot", y, BASINS["steps"], gait=orbit)
        ended = [e for row in basin.ended for e in row]
        counts = {name: ended.count(name) for name in sorted(set(ended))}
        converged = counts.pop("converged", 0)
        others = ", ".join(f"{name} {n}" for name, n in sorted(counts.items(), key=lambda c: -c[1]))
        lines.append(f"| {beta} | {theta_II} | {orbit.max_abs_eigenvalue:.4g} | {converged} | "
                     f"{converged * cell:.3g} | {others} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def _mu_figure(results: dict, out: Path) -> list[Path]:
    from vsw.plots import plotstyle
    from vsw.plots.figures import save_figure

    panels = (("phi_deg", "$\\varphi$ at heelstrike [" + plotstyle.DEG + "]"),
              ("eig", "max $|\\lambda|$"),
              ("energy", "energy added per step [$m_H g l$]"))  # fmt: skip
    with plotstyle.context():
        fig, axes = plotstyle.new_figure(height=1.5 * plotstyle.COLUMN_WIDTH, nrows=3,
                                         sharex=True)  # fmt: skip
        for k, ((beta, theta_II), rows) in enumerate(results.items()):
            mus = [r["mu"] for r in rows]
            for ax, (key, label) in zip(axes, panels):
                ax.plot(mus, [r[key] for r in rows], linestyle="-", **plotstyle.curve_style(k),
                        label=f"$\\beta$ = {beta}, $\\theta_{{II}}$ = {theta_II} rad")  # fmt: skip
                ax.set_ylabel(label)
                ax.set_xscale("log")
        axes[1].axhline(1.0, color=plotstyle.COLORS["grey"], linewidth=0.8)
        axes[-1].set_xlabel("$\\mu = m / m_H$")
        axes[0].set_title("compass-like VSW biped, b / l = 0.3")
        plotstyle.figure_legend(fig, *axes[0].get_legend_handles_labels(), ncols=1)
    return [save_figure(fig, out / f"vsw-biped_mu.{fmt}") for fmt in ("png", "svg")]


def vsw_biped(out: Path, quick: bool = False) -> list[Path]:
    m = load("vsw_biped")
    lines = ["| beta | theta_II | mu | phi at heelstrike (deg) | period | speed | "
             "max abs eigenvalue | energy added per step (m_H g l) | ILE q^f (10) at phi / "
             "biped q | ILE eigenvalue (19) at phi | ILE E_c (20) at phi / biped's energy "
             "added |", "|" + " --- |" * 11]  # fmt: skip
    results = {}
    ends = []
    for beta, theta_II in STUDY[:1] if quick else STUDY:
        results[(beta, theta_II)] = []
        failures: dict = {}
        rows_mu = _mu_rows(m, beta, theta_II, failures)
        last_mu, last = max(((mu, o) for mu, o, _ in rows_mu if o is not None),
                            key=lambda r: r[0])  # fmt: skip
        if any(o is None for mu, o, _ in rows_mu if mu > last_mu):
            end = _branch_end(m, {"beta": beta, "theta_II": theta_II}, "mu", last_mu, 1.0, last)
            ends.append(f"- (beta, theta_II) = ({beta}, {theta_II}): " + (
                f"the branch ends at mu = {end.parameter:.7f}: {end.condition}" if end
                else "no end located up to mu = 1"))  # fmt: skip
        for mu, orbit, params in rows_mu:
            if orbit is None:
                lines.append(f"| {beta} | {theta_II} | {mu:g} | no gait by continuation "
                             f"({failures[mu]}) | | | | | | | |")  # fmt: skip
                continue
            s = orbit.state
            phi = s["psi"] - s["theta"]
            events = {e.name: e for e in m.step_events(params, _vector(orbit))}
            added = events["extension"].energy_change
            q_ile = float(ile.q_fixed(beta, theta_II, phi))
            # The ILE's energy input (20) for its point mass equal to the biped's whole
            # mass, m_H (1 + 2 mu), against the biped's extension work (leg and hip
            # together: the held-hip rule's work has no split).
            added_ile = float(ile.energy_complement(beta, theta_II, phi, q_ile, 1.0 + 2 * mu,
                                                    1.0, 1.0))  # fmt: skip
            lines.append(
                f"| {beta} | {theta_II} | {mu:g} | {math.degrees(phi):.3f} | {orbit.period:.4f} "
                f"| {orbit.speed:.4f} | {orbit.max_abs_eigenvalue:.4g} | {added:.5f} | "
                f"{q_ile / s['theta_dot'] ** 2:.6f} | {float(ile.eigenvalue(beta, phi)):.4g} | "
                f"{added_ile / added:.4f} |"
            )
            results[(beta, theta_II)].append({
                "mu": mu, "phi_deg": math.degrees(phi), "eig": orbit.max_abs_eigenvalue,
                "energy": added,
            })  # fmt: skip
    written = _mu_figure(results, out)
    text = [
        "# The compass-like VSW biped: leg mass ratio mu (b / l = 0.3)\n\n",
        "Assumptions (derive/models/vsw_biped.py; docs/models/vsw_biped.md, 'The extension ",
        "rule'): the stance leg extends instantaneously at theta_II keeping both leg angles ",
        "and both generalised momenta (the held-hip rule: a hip impulse the model does not ",
        "name holds the swing leg); the swing leg swings freely otherwise and shortens to ",
        "beta l at heelstrike; scuffing is reported, not enforced; a step that begins past ",
        "theta_II ends the walk (extension-missed). The same biped under the other rules: ",
        "`vsw-biped-fte` (free hip, extension over delta of stance angle) and ",
        "`vsw-biped-phi0` (the swing leg caught and held at phi0).\n\n",
        "Generated by `python -m paper_check.walkers --model vsw-biped`. The paper's ",
        "future work asks how a swing leg with mass changes Virtual Slope Walking; each ",
        "gait is continued along mu from the least unstable one found at mu = 0.01 (a row ",
        "'no gait by continuation' ends the branch). The last column is the ",
        "ILE's closed-form fixed point (10) at the emergent inter-leg angle over the biped's ",
        "rate squared after heelstrike: 1 + O(mu) (tests/test_vsw_biped.py); beside it the ",
        "ILE's eigenvalue (19) and energy input (20) at that angle, the latter for a point ",
        "mass equal to the biped's whole mass m_H (1 + 2 mu), over the biped's extension ",
        "work (leg and hip together: the held-hip rule's work has no split, ",
        "docs/models/vsw_biped.md).\n\n",
        "\n".join(lines) + "\n\n",
        f"![leg-mass study]({written[0].name})\n",
    ]
    if ends:
        text += [
            "\nWhere a branch ends between the grid's values (located by continuation, ",
            "`vsw continue`, from its last gait on the grid):\n\n",
            "\n".join(ends) + "\n",
        ]
    if not quick:
        text += [
            "\n## Where are the stable gaits?\n\n",
            f"Every period-one gait the scan finds at mu = {SEARCH['mu']}, b / l = 0.3, on a ",
            "grid of (beta, theta_II), the least unstable of each, and a simulated walk from ",
            "it with its rates 1 % off, which says without the eigenvalues whether it ",
            "attracts.\n\n",
            _stable_search(m),
            "\n## The stable region under each extension rule\n\n",
            "The least max |eigenvalue| of the gaits the search finds in each cell (b / l = ",
            "0.3), with the held-hip rule (this model) / with a free hip and the extension ",
            "over 0.3 rad of stance angle (`vsw-biped-fte`); bold: stable; none: no gait ",
            "found.\n\n",
            _region_table({label: stable_region(name, fixed) for name, label, fixed in RULES}),
            "\n## The stable gaits along b / l\n\n",
            f"Each gait of {', '.join(map(str, SWEEP['cells']))} at mu = {SWEEP['mu']} ",
            f"continued from b / l = {SWEEP['b_over_l'][1]} down to {SWEEP['b_over_l'][0]} and ",
            f"up to {SWEEP['b_over_l'][2]} (`vsw continue --over b_over_l`; period-doubled ",
            f"branches followed for {SWEEP['switch']} upwards):\n\n",
            _b_sweep(m),
            "\n## Basins of the stable gaits\n\n",
            f"Starts on a {BASINS['theta_dot'][2]} x {BASINS['psi_dot'][2]} grid of theta_dot ",
            f"in {BASINS['theta_dot'][:2]} and psi_dot in {BASINS['psi_dot'][:2]} at the ",
            f"gait's stance angle (mu = {BASINS['mu']}), walked {BASINS['steps']} steps by the ",
            "batch simulator (`vsw basin --grid`); converged: to the gait within 1e-6.\n\n",
            _basins(m),
        ]
    return _write_report(out / "vsw-biped.md", text, written)


# --- the kneed walker ----------------------------------------------------------------------

HSU_CHEN_GAIT = {"q1": 0.1877, "q1_dot": -1.1014, "heelstrike_angle": 0.2380, "period": 0.559}
"""[HC07] as quoted by [NC26]: just after heelstrike the stance leg's angle from the
vertical and its rate (her sign: positive the other way round), the stance leg's angle from
the slope normal just before heelstrike, the step period (read off a figure)."""


def kneed_walker(out: Path, quick: bool = False) -> list[Path]:
    m = load("kneed_walker")
    params = m.parameters({})
    gamma = params[m.spec["parameters"].index("gamma")]
    (orbit,) = [o for o in m.fixed_points(params) if o.stable]
    s = orbit.state
    moduli = sorted((abs(e) for e in orbit.eigenvalues), reverse=True)
    hc = HSU_CHEN_GAIT
    four = "the source's 4 digits"
    rows = [
        Row("stance angle from the vertical just after heelstrike, q1 (rad)", "HC07",
            hc["q1"], -s["theta"] - gamma, 5e-5, four),
        Row("stance rate just after heelstrike, -q1_dot (rad/s)", "HC07", -hc["q1_dot"],
            s["theta_dot"], 5e-5, four),
        Row("stance angle from the slope normal at heelstrike (rad)", "HC07",
            hc["heelstrike_angle"], -s["theta"], 5e-5, four),
        Row("step period (s)", "HC07", hc["period"], orbit.period, 0.02 * hc["period"],
            "read off a figure (+-2 %) by NC26"),
        Row("half inter-leg angle at heelstrike (rad)", "NC26", 0.23859, -s["theta"], 5e-6,
            "its 5 digits"),
        Row("stance rate just after heelstrike (rad/s)", "NC26", 1.10959, s["theta_dot"],
            5e-6, "its 5 digits"),
        Row("swing rate just after heelstrike (rad/s)", "NC26", 0.05715, s["psi_dot"], 5e-6,
            "its 5 digits"),
        Row("step period (s)", "NC26", 0.5643, orbit.period, 5e-5, "its 4 digits"),
        Row("eigenvalue modulus of the complex pair", "NC26", abs(complex(0.353, 0.552)),
            moduli[0], 1e-3, "0.353 +- 0.552i, 3 digits"),
        Row("real eigenvalue", "NC26", 0.144, moduli[2], 5e-4, "3 digits"),
    ]  # fmt: skip
    knee = next(c for c in gait_conditions(m, params, orbit) if c["name"] == "stance-knee-stop")
    defaults = m.fixed_points(params)
    gaits = ["| gait | theta (rad) | theta_dot (1/s) | psi_dot (1/s) | period (s) "
             "| step length (m) | max abs eigenvalue | stable |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for k, o in enumerate(defaults, 1):
        g = o.state
        gaits.append(f"| {k} | {g['theta']:.10f} | {g['theta_dot']:.10f} | "
                     f"{g['psi_dot']:.10f} | {o.period:.10f} | {o.step_length:.10f} | "
                     f"{o.max_abs_eigenvalue:.6f} | {'yes' if o.stable else 'no'} |")  # fmt: skip
    text = [
        "# The kneed walker beside its sources\n\n",
        "Generated by `python -m paper_check.walkers --model kneed-walker`. Parameters: HC07's ",
        "(m_H = m_t = 0.5 kg, m_s = 0.05 kg, a1 = 0.375, b1 = 0.125, a2 = 0.175, b2 = 0.325 m, ",
        "gamma = 0.0504 rad, g = 9.81 m/s^2). Her angles are from the vertical with the ",
        "opposite sign: q1 = -(theta + gamma), q2 = -(psi + gamma), q3 = q2 - kappa.\n\n",
        _sources(["HC07", "NC26"]),
        "## The stable gait\n\n",
        _table(rows),
        "\nHC07's gait differs from ours by 0.2 % in the angles and 0.7 % in the stance ",
        "rate, beyond her digits; NC26's, a re-implementation as independent of ours as of ",
        "hers, agrees with ours to all its digits, eigenvalues included. What HC07 did ",
        "otherwise is not known to us (her thesis was not at hand). Both impacts as here: ",
        "knee strike conserves the generalised momenta of the stance and thigh angles (the ",
        "lock's impulse acts on the knee angle alone); at heelstrike the new swing knee is ",
        "held straight through the impact.\n\n",
        "## The stance knee\n\n",
        "HC07 (like McGeer) keeps the stance knee locked. The torque its lock exerts is ",
        "derived (the condition stance-knee-stop, reported, not enforced): on this gait its ",
        f"least value is {knee['margin']:.4g} {knee['unit']}, so for part of the knee-free ",
        "phase the lock must pull the knee straight; a stop alone would let it buckle, and ",
        "the walker needs a latch there.\n\n",
        "## Every gait at the defaults\n\n",
        "\n".join(gaits) + "\n",
    ]
    return _write_report(out / "kneed-walker.md", text, [])


REPORTS: dict[str, Callable[[Path, bool], list[Path]]] = {
    "simplest-walker": simplest_walker,
    "compass-gait": compass_gait,
    "vsw-biped": vsw_biped,
    "kneed-walker": kneed_walker,
    "point-mass-biped": point_mass_biped,
    "kuo-walker": kuo_walker,
    "free-vsw-biped": free_vsw_biped,
}


def main(argv: list[str] | None = None) -> int:
    """Write the reports of the models asked for (default: all); exit 2 on a bad ``--out``
    or model name (one line). A row that differs is a finding to read, not a failure: the
    tests (tests/test_passive_walkers.py) hold which rows must agree."""
    parser = argparse.ArgumentParser(
        prog="python -m paper_check.walkers",
        description="The walkers with massive legs beside their published numbers.",
    )
    parser.add_argument("--model", action="append", choices=MODELS, metavar="NAME",
                        help=f"one of {', '.join(MODELS)}; repeatable (default: all)")  # fmt: skip
    parser.add_argument("--out", default="reports/walkers",
                        help="output directory (default: reports/walkers)")  # fmt: skip
    parser.add_argument("--quick", action="store_true",
                        help="coarse diagrams and one biped case (for tests)")  # fmt: skip
    args = parser.parse_args(argv)
    problem = check_output_directory(args.out, figures=False)
    if problem is not None:
        print(f"paper_check.walkers: error: {problem}", file=sys.stderr)
        return 2
    out = Path(args.out)
    for name in args.model or MODELS:
        start = time.perf_counter()
        for path in REPORTS[name](out, args.quick):
            print(path)
        print(f"paper_check.walkers: {name} in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
