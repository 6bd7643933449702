"""Cases 9, 10, 12 and 14: the passive walkers' gaits (the rootfinder, one step of the
batch simulator, the gait search, continuation to a flip) against SciPy and finer grids;
and the gaits and starts near them that other cases begin from."""

from __future__ import annotations

import time

import numpy as np
from harness import Row, Timing, interleaved, timed


# Case 9's gaits and the published numbers each is held against (sources as in
# tests/test_passive_walkers.py): the simplest walker's long gait at gamma = 0.009 (Garcia's
# code: theta, theta_dot in its signs, "to 1e-10"); the compass gait at 3 degrees (Goswami
# et al. 1996 as quoted: half inter-leg angle 0.271 rad, 3 digits); the VSW biped (no
# published number: the ILE's closed form (10) at the emergent angle, mu = 0.01, is its
# O(mu) check, not a published value).
def _gaits():
    from paper_check.walkers import GARCIA_LONG

    theta, theta_dot = GARCIA_LONG
    return (
        ("simplest_walker", {"gamma": 0.009},
         lambda s: max(abs(-s["theta"] - theta), abs(-s["theta_dot"] - theta_dot))),
        ("compass_gait", {"gamma": float(np.radians(3.0))}, lambda s: abs(-s["theta"] - 0.271)),
        ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 0.01}, None),
    )  # fmt: skip


def _most_stable_gait(m, params):
    """The model's most stable gait from a coarse search (24 points a side): the cases that
    start from it time what follows, not the search (vsw.gaits.search; its own default is finer,
    to find the gaits with tiny basins too)."""
    from vsw.gaits.search import search

    found = search(m, params, cells=24 ** len(m.spec["search"]))
    return min(found.gaits, key=lambda o: o.max_abs_eigenvalue)


def case_gait_rootfinder(reps: int) -> list[Row]:
    """Case 9: one period-one gait per model by the engine's boundary-value rootfinder
    (CasADi Newton on CVODES flows, eigenvalues included, confirmed by one simulated step)
    against SciPy root (hybr, xtol 1e-12) on the simulated map (solve_ivp DOP853 with
    events, rtol = atol = 1e-12: vsw.dynamics.hybrid's own step), both from the same guess: the gait
    with every component moved by 1e-3 (relative), as a continuation step leaves it."""
    from scipy.optimize import root

    from vsw.models import load

    rows = []
    for key, values, published in _gaits():
        m = load(key)
        params = m.parameters(values)
        orbit = _most_stable_gait(m, params)
        x_star = np.array(list(orbit.state.values()))
        guess = x_star * (1 + 1e-3)
        durations = m.step(params, guess).durations
        found = {}

        def ours(m=m, params=params, guess=guess, durations=durations, found=found):
            found["ours"] = m.periodic_orbit(params, guess, durations)

        def theirs(m=m, params=params, guess=guess, found=found):
            solution = root(lambda x: m.step(params, x).state - x, guess, method="hybr",
                            options={"xtol": 1e-12})  # fmt: skip
            found["theirs"] = solution

        t_ours, t_theirs = interleaved(ours, theirs, reps)
        x_ours = np.array(list(found["ours"].state.values()))
        x_theirs = found["theirs"].x
        names = m.coordinates + m.rates
        note = (f"SciPy root success {found['theirs'].success}, {found['theirs'].nfev} steps; "
                f"the two gaits differ by {np.max(np.abs(x_ours - x_theirs)):.1g}")  # fmt: skip
        if published is not None:
            gap_ours = published(found["ours"].state)
            gap_theirs = published(dict(zip(names, x_theirs)))
            note += (f"; from the published values: ours {gap_ours:.2g}, SciPy's "
                     f"{gap_theirs:.2g}")  # fmt: skip
        ratio = t_ours.median / t_theirs.median
        # Of ours, the simulated step that confirms the orbit (SciPy, as the baseline's).
        t_step = timed(lambda m=m, params=params, x=x_ours: m.step(params, x), reps)
        note += f"; of ours, the confirming simulated step {t_step.median * 1e3:.1f} ms"
        rows.append(Row(
            "9", f"{key}: period-one gait by vsw.dynamics.hybrid periodic_orbit",
            "SciPy root on solve_ivp (DOP853, events) steps", t_ours, t_theirs,
            ">= 20x faster", ratio <= 1 / 20, note=note,
        ))  # fmt: skip
        # The same gait as a fixed point of the compiled batch simulator's map (Newton with
        # central differences), against the same baseline, side by side.
        from vsw.dynamics.batch import simulator
        from vsw.dynamics.step_map import fixed_point

        sim = simulator(load(key))
        sim.library()

        def batch(sim=sim, params=params, guess=guess, found=found):
            found["batch"] = fixed_point(sim, params, guess)[0]

        t_batch, t_theirs = interleaved(batch, theirs, reps)
        gap = np.max(np.abs(found["batch"] - x_ours))
        note = (
            f"the batch fixed point and the rootfinder's differ by {gap:.1g}; no "
            "eigenvalues or confirmation step in this time (periodic_orbit has both)"
        )
        ratio = t_batch.median / t_theirs.median
        rows.append(Row(
            "9", f"{key}: period-one gait by the batch simulator's Newton (vsw.dynamics.batch)",
            "SciPy root on solve_ivp (DOP853, events) steps", t_batch, t_theirs,
            ">= 20x faster", ratio <= 1 / 20, note=note,
        ))  # fmt: skip
    return rows


def _near_gait_starts(key: str, count: int, values: dict | None = None):
    """The model's default parameters (or these ``values``), its most stable gait and
    ``count`` section states around it (1 % relative noise, fixed seed) that all complete
    a step."""
    from vsw.dynamics.batch import WALKED, simulator
    from vsw.models import load

    m = load(key)
    params = m.parameters(values)
    orbit = _most_stable_gait(m, params)
    x = np.array(list(orbit.state.values()))
    starts = x * (1 + 0.01 * np.random.default_rng(14).standard_normal((4 * count, x.size)))
    if m.spec.get("section"):
        starts = np.column_stack(m.module.section_completion(*params, *starts.T))
    ok = simulator(load(key)).step(params, starts).outcome == WALKED
    return m, params, starts[ok][:count]


def case_batch_step(count: int, reps: int) -> list[Row]:
    """Case 10: one step of the Poincare map from each of ``count`` section states near the
    gait: the compiled batch simulator (one thread, one call) at its default rtol = atol =
    1e-12 against SciPy's solve_ivp (DOP853, events; vsw.dynamics.hybrid's step) at 1e-10 (the
    target's baseline) and at 1e-12 (the same tolerance), and both at 1e-10."""
    import vsw.dynamics.hybrid as hybrid
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        m, params, starts = _near_gait_starts(key, count)
        sim = simulator(load(key))
        sim.library()
        found = {}

        for our_tol, tol in ((1e-12, 1e-10), (1e-12, 1e-12), (1e-10, 1e-10)):

            def ours(sim=sim, params=params, starts=starts, found=found, our_tol=our_tol):
                found["ours"] = sim.step(params, starts, threads=1, tolerance=our_tol).final

            def theirs(m=m, params=params, starts=starts, found=found, tol=tol):
                saved = hybrid.RTOL, hybrid.ATOL
                hybrid.RTOL = hybrid.ATOL = tol
                try:
                    found["theirs"] = np.array([m.step(params, x).state for x in starts])
                finally:
                    hybrid.RTOL, hybrid.ATOL = saved

            t_ours, t_theirs = interleaved(ours, theirs, reps)
            gap = np.max(np.abs(found["ours"] - found["theirs"])
                         / np.maximum(1, np.abs(found["theirs"])))  # fmt: skip
            ratio = t_ours.median / t_theirs.median
            rows.append(Row(
                "10", f"{key}: one step per start, batch simulator (1 thread) at rtol = atol "
                f"= {our_tol:g}", f"solve_ivp DOP853 + events, rtol = atol = {tol:g}",
                t_ours.per(len(starts)), t_theirs.per(len(starts)), ">= 300x faster",
                ratio <= 1 / 300,
                note=f"per step over {len(starts)} starts; post-step states differ by at most "
                f"{gap:.1g} (relative)",
            ))  # fmt: skip
        rows.append(_sampled_step_row(key, m, params, sim, reps))
    return rows


def _sampled_step_row(key: str, m, params, sim, reps: int) -> Row:
    """Case 10: the step a gait's conditions are read on (vsw.dynamics.conditions: the
    integrator's steps at most period / SAMPLES), compiled (``sampled_step``) against
    SciPy's (``HybridModel.simulate``), and how far apart their samples are."""
    from vsw.dynamics.conditions import SAMPLES

    orbit = _most_stable_gait(m, params)
    state = np.array(list(orbit.state.values()))
    max_step = orbit.period / SAMPLES
    found = {}

    def ours():
        found["ours"] = sim.sampled_step(params, state, max_step)

    def theirs():
        found["theirs"] = m.simulate(params, state, 1, max_step=max_step)

    t_ours, t_theirs = interleaved(ours, theirs, reps)
    a, b = found["ours"], found["theirs"]
    same = len(a.t) == len(b.t) and np.array_equal(a.phase, b.phase)
    gap = float(np.max(np.abs(a.states - b.states))) if same else float("nan")
    return Row(
        "10", f"{key}: one step of a gait sampled for its conditions (steps <= period / "
        f"{SAMPLES}), compiled", "HybridModel.simulate (solve_ivp DOP853 + events, the same "
        "max_step)", t_ours, t_theirs, ">= 100x faster",
        t_ours.median / t_theirs.median <= 1 / 100,
        note=f"{len(a.t)} samples against {len(b.t)}, "
        + (f"the same phases, states at most {gap:.1g} apart" if same else "NOT the same"),
    )  # fmt: skip


GAIT_SEARCH_SETS = (
    ("simplest_walker", {}),
    ("compass_gait", {}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 1e-4, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 1e-3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.85, "theta_II": 0.05, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.85, "theta_II": 0.05, "mu": 1.0, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.99, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3}),
)
"""Where the gait search is checked against a scan twice as fine (case 12): the passive
walkers' defaults and the biped's sets of tests/test_gaits.py."""


MILD = 100.0
"""Case 12's bound: gaits with a max |eigenvalue| below it (every gait a walker could use
or a controller hold) must all be found; the very unstable ones near falling back lie in
ever thinner bands of states and are found where the grid resolves them."""


def case_gait_search(quick: bool) -> list[Row]:
    """Case 12: the gait search (vsw.gaits.search) as analyze runs it, one run per set, against a
    scan twice as fine along every free component (4 times the cells in two components,
    8 in three): the gaits the finer scan adds (each component apart by more than 1e-8),
    none of them with max |eigenvalue| below :data:`MILD`. Quick: the rimless wheel only."""
    from vsw.gaits import search as gaits
    from vsw.models import load

    sets = (("rimless_wheel", {}),) if quick else GAIT_SEARCH_SETS
    rows = []
    for key, values in sets:
        m = load(key)
        params = m.parameters(values)
        dims = len(m.spec["search"])
        points = gaits.SCAN_POINTS[dims]
        start = time.perf_counter()
        default = gaits.search(m, params)
        t_default = time.perf_counter() - start
        start = time.perf_counter()
        finer = gaits.search(m, params, cells=(2 * points) ** dims)
        t_finer = time.perf_counter() - start

        def states(found):
            return [np.array(list(g.state.values())) for g in found.gaits]

        extra = [g for g, y in zip(finer.gaits, states(finer))
                 if all(np.max(np.abs(y - x)) > 1e-8 for x in states(default))]  # fmt: skip
        mild = [g for g in extra if g.max_abs_eigenvalue < MILD]
        moduli = ", ".join(f"{g.max_abs_eigenvalue:.4g}" for g in default.gaits)
        added = ", ".join(f"{g.max_abs_eigenvalue:.4g}" for g in extra) or "none"
        label = f"{key} {values}" if values else f"{key} (defaults)"
        rows.append(Row(
            "12", f"gait search, {label}: {points} points a side ({default.cells} cells)",
            f"scan twice as fine ({finer.cells} cells)", Timing.of([t_default]),
            Timing.of([t_finer]), f"the finer scan finds no other gait with max |eigenvalue| "
            f"< {MILD:g}", None if quick else not mild,
            note=f"{len(default.gaits)} gaits (max |eigenvalue| {moduli}); the finer scan adds "
            f"{added}; Newton from {default.candidates} completed cells",
        ))  # fmt: skip
    return rows


def case_locate_flip(quick: bool) -> list[Row]:
    """Case 14: the simplest walker's first flip from gamma = 0.009, located by
    ``vsw continue``'s library call (Garcia et al. 1998's long gait, continued without
    switching to the flip's bracket below 1e-11 of the range) against ``vsw sweep``'s
    continuation on a grid, one run each in this process. A grid locates the flip only to
    its spacing: the grid of the same precision is far too large to run, so its time is the
    measured grid's per point times the points it would need (stated as extrapolated).
    Quick: a 5-point grid."""
    from vsw.gaits import continuation
    from vsw.models import load
    from vsw.studies import sweeps

    m = load("simplest_walker")
    long_gait = (-0.200310900563820, -0.400621801127640, 0.199832473025474,
                 0.015822999949030)  # fmt: skip  # Bhounsule 2013, as paper_check quotes
    start, stop_value = 0.009, 0.016
    params = m.parameters({"gamma": start})
    guess_durations = m.step(params, np.array(long_gait)).durations
    begin = time.perf_counter()
    (branch,) = continuation.continue_gaits(
        m, params, "gamma", start, stop_value, long_gait, guess_durations,
        options=continuation.Options(switch=False),
    )  # fmt: skip
    t_continue = time.perf_counter() - begin
    flip = next(s for s in branch.special_points if s.type == "flip")
    precision = continuation.LOCATE_TOL * (stop_value - start)
    count = 5 if quick else 71
    grid = np.linspace(start, stop_value, count)
    begin = time.perf_counter()
    points = sweeps.continuation(m, {}, "gamma", grid)
    t_grid = time.perf_counter() - begin
    lost = next((p["gamma"] for p in points if p["max_abs_eigenvalue"] is not None
                 and p["max_abs_eigenvalue"] > 1), None)  # fmt: skip
    spacing = grid[1] - grid[0]
    needed = (stop_value - start) / precision
    extrapolated = t_grid / count * needed
    return [Row(
        "14", f"vsw continue locates the simplest walker's first flip at gamma = "
        f"{flip.parameter:.12f} (|mu + 1| = {flip.defining:.1g}, bracket {precision:.1g})",
        f"vsw sweep on {count} values (spacing {spacing:.2g}: its first unstable value "
        f"{lost}), extrapolated to the spacing {precision:.1g} ({needed:.2g} values)",
        Timing.of([t_continue]), Timing.of([extrapolated]),
        "locating the flip by continuation faster than a grid of equal precision",
        None if quick else t_continue < extrapolated,
        note=f"the {count}-value grid itself took {t_grid:.3g} s; {len(branch.points)} "
        "continuation points",
    )]  # fmt: skip
