"""The compiled batch simulator (vsw.dynamics.batch) against the models' own SciPy simulation.

The reference is :meth:`vsw.dynamics.hybrid.HybridModel.step`: SciPy's DOP853 with event functions
(dense output and brentq), an implementation independent of vsw/dynamics/csrc/hybrid_batch.c
(its own DOP853 loop, events located by the Illinois method on the dense output). Also
checked: the DOP853 table against SciPy's, the fixed point against the CasADi rootfinder,
the section declarations against simulated steps, and determinism over blocks and threads.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import committed_gaits
from vsw.dynamics.batch import CONVERGED, FELL, WALKED, Options, reference_walks, simulator
from vsw.dynamics.step_map import fixed_point
from vsw.models import keys, load

pytest.importorskip("casadi")

MODELS = ("simplest_walker", "compass_gait", "vsw_biped", "rimless_wheel", "ile", "tle")
STATE_TOL = 1e-9  # the bound on the post-step state, relative


@pytest.fixture(scope="module")
def gaits():
    """Each model's gaits at its defaults: the kept ones, confirmed by compiled steps and a
    Newton solve (tests.conftest.committed_gaits), or the search's for a model not kept."""
    out = {}
    for name in MODELS:
        committed = committed_gaits(name)
        if committed is None:
            model = load(name)
            params = model.parameters()
            committed = (model, params, model.fixed_points(params))
        out[name] = committed
    return out


def test_dop853_table_is_scipys():
    from scipy.integrate._ivp import dop853_coefficients as ref

    text = (
        Path(__file__).resolve().parent.parent / "vsw/dynamics/csrc/dop853_tableau.h"
    ).read_text()

    def array(name):
        body = re.search(rf"{name}\[[^=]*= \{{(.*?)\}};", text, flags=re.S).group(1)
        return np.array([float(v) for v in re.findall(r"-?\d[\d.e+-]*", body)])

    stages = 12
    assert np.array_equal(array("vsw_rk_c"), ref.C[:stages])
    assert np.array_equal(array("vsw_rk_b"), ref.B)
    assert np.array_equal(array("vsw_rk_e5"), ref.E5)
    assert np.array_equal(array("vsw_rk_e3"), ref.E3)
    assert np.array_equal(array("vsw_rk_a").reshape(stages, stages), ref.A[:stages, :stages])
    # the dense output's extra stages and interpolant
    assert np.array_equal(array("vsw_rk_c_extra"), ref.C[stages + 1 :])
    assert np.array_equal(array("vsw_rk_a_extra").reshape(3, 16), ref.A[stages + 1 :])
    assert np.array_equal(array("vsw_rk_d").reshape(4, 16), ref.D)


def _boundary_starts(model, params, state, component, sim, rng):
    """Starts within 1e-7 of where one step's outcome changes along ``component`` (near
    falling, near lift-off, near a grazing event): found by bisection on the batch
    simulator, then sampled on both sides."""
    x = np.tile(state, (400, 1))
    x[:, component] *= np.linspace(0.3, 2.5, 400)
    ended = sim.step(params, x).ended()
    starts = []
    for i in range(len(x) - 1):
        if ended[i] == ended[i + 1]:
            continue
        lo, hi = x[i].copy(), x[i + 1].copy()
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if sim.step(params, mid[None]).ended()[0] == ended[i]:
                lo = mid
            else:
                hi = mid
        for offset in (-1e-7, -1e-9, 1e-9, 1e-7):
            starts.append(
                0.5 * (lo + hi) + offset * (x[i + 1] - x[i]) / np.abs(x[i + 1] - x[i]).max()
            )
    return starts


@pytest.mark.parametrize("name", [*MODELS, "kneed_walker", "torso_walker"])
def test_hoisted_constants_change_no_function_of_the_table(name):
    """The table's functions of (c, x), c = constants(p) (derive/sim_codegen.py,
    _hoist_parameters), against the same functions of (p, x) before the hoisting (every
    function the C table holds, built as simulator_c_source builds them), both
    evaluated by CasADi's virtual machine at 50 random states: equal bit for bit (the
    same operations in the same order, some done once a walk)."""
    import casadi as ca

    import derive.sim_codegen as sim_codegen

    model = load(name)
    t = sim_codegen.table(model.spec, model.module, "")
    p, x, outputs = t.p, t.x, [out for _, out in t.pending]
    constants, c, hoisted = sim_codegen._hoist_parameters(p, x, outputs)
    assert 0 < constants.numel() and not ca.depends_on(constants, x)
    before = ca.Function("before", [p, x], outputs)
    after = ca.Function("after", [c, x], hoisted)
    constants_of = ca.Function("constants", [p], [constants])
    params = np.asarray(model.parameters(), dtype=float)
    rng = np.random.default_rng(3)
    for state in rng.uniform(-1.0, 1.0, (50, x.numel())):
        want = [np.asarray(v) for v in before(params, state)]
        got = [np.asarray(v) for v in after(constants_of(params), state)]
        for w, g in zip(want, got):
            assert np.array_equal(w, g, equal_nan=True)


@pytest.mark.parametrize("name", MODELS)
def test_batch_step_equals_scipy_step(gaits, name):
    """<= 1e-9 relative on the post-step state (and equal outcomes), on random starts
    around every gait and on starts within 1e-7 of where the outcome changes."""
    model, params, orbits = gaits[name]
    sim = simulator(load(name))
    assert sim.library() is not None, sim.build_error
    rng = np.random.default_rng(14)
    starts, near = [], []
    for orbit in orbits[:2]:
        state = np.array([orbit.state[k] for k in (*model.coordinates, *model.rates)])
        starts += list(state * (1 + 0.05 * rng.standard_normal((25, len(state)))))
        rate = model.n  # the first rate: how fast the stance leg swings
        edge = _boundary_starts(model, params, state, rate, sim, rng)
        near += range(len(starts), len(starts) + len(edge))
        starts += edge
    starts = np.array(starts)
    batch = sim.step(params, starts)
    ref = reference_walks(model, params, starts, Options(1, None, 0.0, 0.0, 0, 1))
    # Within 1e-7 of an outcome boundary either route may be on either side (a guard that
    # dips through zero inside one integrator step is seen by neither, and their steps
    # differ); everywhere else the outcomes are equal.
    differ = [i for i, (a, b) in enumerate(zip(batch.ended(), ref.ended())) if a != b]
    assert set(differ) <= set(near), differ
    assert len(differ) <= len(near) // 2
    # Where the walk falls, both keep the section state the failing step started from.
    same = np.array(batch.ended()) == np.array(ref.ended())
    assert np.array_equal(batch.final[same & (batch.outcome != WALKED)],
                          ref.final[same & (ref.outcome != WALKED)])  # fmt: skip
    done = (batch.outcome == WALKED) & (ref.outcome == WALKED)
    assert done.sum() >= 10
    scale = np.maximum(1.0, np.abs(ref.final))
    relative = np.max(np.abs(batch.final - ref.final) / scale, axis=1)
    is_near = np.zeros(len(starts), bool)
    is_near[near] = True
    assert np.max(relative[done & ~is_near]) <= STATE_TOL
    # Within 1e-7 of an outcome boundary the step is ill-conditioned too: the simplest
    # walker's start 1e-9 from a grazing swing walks a 17.6-long step whose end the two
    # routes put 2.7e-9 apart on an Intel Xeon (within 1e-9 on an AMD EPYC): last-bit
    # differences of the CPU's libm, amplified by the near-grazing.
    assert np.max(relative[done & is_near], initial=0.0) <= 100 * STATE_TOL
    if model.spec["step_length"]:
        gap = np.abs(batch.kept_lengths[:, 0] - ref.kept_lengths[:, 0])
        assert np.max(gap[done & ~is_near]) <= STATE_TOL
        assert np.max(gap[done & is_near], initial=0.0) <= 100 * STATE_TOL
    # The step's duration too, away from the boundaries: near the apex bound the time a
    # slow walker takes to pass it is ill-conditioned (1.8e-8 apart on the rimless wheel).
    far = done.copy()
    far[near] = False
    gap = np.abs(batch.kept_durations[far, 0] - ref.kept_durations[far, 0])
    assert np.max(gap) <= STATE_TOL * np.max(ref.kept_durations[far, 0])
    assert len(near) >= 4, "no outcome boundary found along the rate"


@pytest.mark.parametrize("name", MODELS)
def test_step_with_each_phase_duration_equals_scipys(gaits, name):
    """`step_phases` (the gait search's guess of the phase durations and the confirmation
    of every gait) against the SciPy route's step: the same phases visited, each visit's
    duration, the state after and the step length within 1e-9, on starts around each gait;
    a fall names the same failure."""
    model, params, orbits = gaits[name]
    sim = simulator(load(name))
    assert sim.library() is not None, sim.build_error
    rng = np.random.default_rng(27)
    names = (*model.coordinates, *model.rates)
    compared = {"completed": 0, "fell": 0}
    for orbit in orbits[:2]:
        state = np.array([orbit.state[k] for k in names])
        slow = state.copy()
        slow[model.n :] *= 0.05  # too slow to pass mid-stance: it falls back
        starts = [state, slow, *(state * (1 + 0.05 * rng.standard_normal((12, len(state)))))]
        for start in starts:
            ours, ref = sim.step_phases(params, start), model.step(params, start)
            assert ours.ended == ref.ended
            assert len(ours.durations) == len(ref.durations)
            if ref.ended == "completed":
                compared["completed"] += 1
                assert np.allclose(ours.durations, ref.durations, rtol=0, atol=STATE_TOL)
                scale = np.maximum(1.0, np.abs(ref.state))
                assert np.max(np.abs(ours.state - ref.state) / scale) <= STATE_TOL
                if ref.step_length is None:
                    assert ours.step_length is None
                else:
                    assert abs(ours.step_length - ref.step_length) <= STATE_TOL
            else:
                compared["fell"] += 1
                # the fall's own time: where the failure's guard crosses
                assert np.allclose(ours.durations, ref.durations, rtol=0, atol=STATE_TOL)
    assert compared["completed"] >= 5 and compared["fell"] >= 1, compared


@pytest.mark.parametrize("name", [*MODELS[:4], "kneed_walker"])
def test_a_sampled_step_is_the_scipy_routes_samples(gaits, name):
    """`sampled_step` (the samples every gait's conditions are read on) against the SciPy
    route's `simulate` of one step at the same largest step: the same number of samples in
    the same phases (each phase's start, each accepted step, each event twice: the
    simplest walker's scuff at the start and the kneed walker's knee lock among them), the
    times and states within 1e-9, the same end; from each gait, starts around it, one that
    falls back, and at a largest step that takes more samples than the first try has room
    for."""
    if name == "kneed_walker":
        model = load(name)
        params = model.parameters()
        orbits = model.fixed_points(params)
    else:
        model, params, orbits = gaits[name]
    sim = simulator(load(name))
    assert sim.library() is not None, sim.build_error
    rng = np.random.default_rng(31)
    names = (*model.coordinates, *model.rates)
    ended = Counter()
    for orbit in orbits[:2]:
        state = np.array([orbit.state[k] for k in names])
        slow = state.copy()
        slow[model.n :] *= 0.05  # too slow to pass mid-stance: it falls back
        starts = [state, slow, *(state * (1 + 0.02 * rng.standard_normal((4, len(state)))))]
        for start, fraction in [*((s, 400) for s in starts), (state, 3000)]:
            max_step = orbit.period / fraction
            ours = sim.sampled_step(params, start, max_step)
            ref = model.simulate(params, start, 1, max_step=max_step)
            assert (ours.ended, ours.steps_completed) == (ref.ended, ref.steps_completed)
            assert np.array_equal(ours.phase, ref.phase), (len(ours.phase), len(ref.phase))
            assert np.max(np.abs(ours.t - ref.t)) <= STATE_TOL
            scale = np.maximum(1.0, np.abs(ref.states))
            assert np.max(np.abs(ours.states - ref.states) / scale) <= STATE_TOL
            assert np.max(np.abs(ours.section - ref.section)) <= STATE_TOL
            ended[ours.ended == "completed"] += 1
            if fraction == 3000:
                assert len(ours.t) > 3000  # past the first try's room
    assert ended[True] >= 5 and ended[False] >= 1, ended
    if name in ("simplest_walker", "vsw_biped", "kneed_walker"):
        # an event point twice inside the step: a scuff's restart, a phase's change
        inside = np.flatnonzero(np.diff(ref.t[:-2]) == 0)
        assert len(inside) and np.array_equal(inside, np.flatnonzero(np.diff(ours.t[:-2]) == 0))
    assert ours.t[-1] == ours.t[-2] and np.array_equal(ours.states[-1], ours.states[-2])


@pytest.mark.parametrize("name", ["simplest_walker", "vsw_biped", "rimless_wheel"])
def test_a_steps_events_are_the_scipy_routes(gaits, name):
    """`step_events` by the compiled integrator (the impacts' losses of every design)
    against the SciPy route's: the same events in order, their times, states on either
    side and energies within 1e-9; none for a start that falls before its first event."""
    model, params, orbits = gaits[name]
    sim = simulator(load(name))
    rng = np.random.default_rng(5)
    names = (*model.coordinates, *model.rates)
    compared = 0
    for orbit in orbits[:2]:
        state = np.array([orbit.state[k] for k in names])
        slow = state.copy()
        slow[model.n :] *= 0.05
        for start in (state, slow, *(state * (1 + 0.02 * rng.standard_normal((3, len(state)))))):
            ours, ref = sim.step_events(params, start), model.step_events(params, start)
            assert [e.name for e in ours] == [e.name for e in ref]
            for a, b in zip(ours, ref):
                assert abs(a.time - b.time) <= STATE_TOL
                assert np.max(np.abs(a.state_before - b.state_before)) <= STATE_TOL
                assert np.max(np.abs(a.state_after - b.state_after)) <= STATE_TOL
                assert abs(a.energy_before - b.energy_before) <= STATE_TOL
                assert abs(a.energy_after - b.energy_after) <= STATE_TOL
                compared += 1
    assert compared >= 4


def test_a_sampled_step_needs_a_positive_largest_step(gaits):
    from vsw.runtime.errors import VswInputError

    model, params, orbits = gaits["compass_gait"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(VswInputError, match="max_step must be positive"):
            simulator(load("compass_gait")).sampled_step(params, state, bad)


def test_a_sampled_step_and_events_without_a_compiler_are_scipys(gaits, monkeypatch):
    model, params, orbits = gaits["compass_gait"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    monkeypatch.setenv("VSW_KERNELS", "0")
    from vsw.dynamics.batch import BatchSimulator

    fallback = BatchSimulator(model)
    ours = fallback.sampled_step(params, state, 0.01)
    ref = model.simulate(params, state, 1, max_step=0.01)
    assert np.array_equal(ours.states, ref.states) and np.array_equal(ours.t, ref.t)
    events = fallback.step_events(params, state)
    assert [e.state_after.tobytes() for e in events] == [
        e.state_after.tobytes() for e in model.step_events(params, state)
    ]


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait", "vsw_biped", "rimless_wheel"])
def test_batch_fixed_point_equals_the_rootfinders(gaits, name):
    model, params, orbits = gaits[name]
    sim = simulator(load(name))
    # From 1e-4 off, plain Newton on the simulated map; the gaits with |eigenvalue| in the
    # hundreds (the compass gait's and the biped's the search finds near falling back) need
    # the search's start from a completing state instead.
    for orbit in (o for o in orbits if o.max_abs_eigenvalue < 50):
        state = np.array([orbit.state[k] for k in (*model.coordinates, *model.rates)])
        found, jacobian = fixed_point(sim, params, state * (1 + 1e-4))
        assert np.max(np.abs(found - state)) <= 1e-10 * max(1.0, np.max(np.abs(state)))
        # the map's derivative by differences of batch steps has the rootfinder's spectrum
        moduli = sorted(abs(np.linalg.eigvals(jacobian)))[-1]
        assert moduli == pytest.approx(orbit.max_abs_eigenvalue, rel=1e-5)


def _cells(model, params, target, count, rng):
    """Random section states of the simplest walker around its thin basin (Schwab and
    Wisse 2001: a narrow band through the gait, theta_dot falling as theta grows)."""
    theta = rng.uniform(-0.36, -0.14, count)
    theta_dot = target[2] - 0.95 * (theta - target[0]) + rng.uniform(-0.01, 0.01, count)
    base = np.tile(target, (count, 1))
    base[:, 0], base[:, 2] = theta, theta_dot
    return np.column_stack(model.module.section_completion(*params, *base.T))


@pytest.mark.slow
def test_classification_of_500_cells_equals_the_scipy_route(gaits):
    """Every class equal, except cells whose class changes within 1e-6 of them (a class
    boundary: then the two routes may differ; none did when this was written)."""
    model, params, orbits = gaits["simplest_walker"]
    stable = next(o for o in orbits if o.stable)
    target = np.array([stable.state[k] for k in (*model.coordinates, *model.rates)])
    cells = _cells(model, params, target, 500, np.random.default_rng(2001))
    sim = simulator(load("simplest_walker"))
    options = dict(target=target, converge_tol=1e-6, period_tol=1e-6, max_period=8)
    batch = sim.walk(params, cells, 50, **options)
    ref = reference_walks(model, params, cells, Options(50, tuple(target), 1e-6, 1e-6, 8, 0))
    counts = Counter(batch.labels())
    assert counts["converged"] >= 50 and counts["fell"] >= 50, counts
    differ = [i for i, (a, b) in enumerate(zip(batch.labels(), ref.labels())) if a != b]
    for i in differ:
        nudged = cells[i] + 1e-6 * np.array(
            [[1, 2, 0, 0], [-1, -2, 0, 0], [0, 0, 1, 0], [0, 0, -1, 0]]
        )
        labels = set(sim.walk(params, nudged, 50, **options).labels())
        assert len(labels) > 1, f"cell {i}: {batch.labels()[i]} vs {ref.labels()[i]} off a boundary"
    assert len(differ) <= 5
    same = [i for i in range(len(cells)) if i not in differ]
    assert np.array_equal(batch.steps[same], ref.steps[same])


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait"])
def test_declared_section_holds_after_simulated_steps(gaits, name):
    """The section a model declares (phi = 2 theta and the swing rate the impact gives;
    psi = -theta) is what the SciPy-simulated heelstrike produces."""
    model, params, orbits = gaits[name]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    rng = np.random.default_rng(3)
    checked = 0
    for start in state * (1 + 0.02 * rng.standard_normal((12, len(state)))):
        result = model.step(params, start)
        if result.ended != "completed":
            continue
        completed = np.array(model.module.section_completion(*params, *result.state), float)
        assert np.max(np.abs(completed - result.state)) <= 1e-12
        checked += 1
    assert checked >= 5


def test_results_do_not_depend_on_blocks_or_threads(gaits, monkeypatch):
    import vsw.dynamics.batch as batch_module

    model, params, orbits = gaits["compass_gait"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = state * (1 + 0.03 * np.random.default_rng(5).standard_normal((300, 4)))
    sim = simulator(load("compass_gait"))
    one = sim.walk(params, starts, 12, keep=3, threads=1)
    monkeypatch.setattr(batch_module, "CHUNK", 7)
    two = sim.walk(params, starts, 12, keep=3, threads=2)
    fields = ("outcome", "aux", "steps", "final", "kept_states", "kept_lengths",
              "kept_durations")  # fmt: skip
    for field in fields:
        a, b = getattr(one, field), getattr(two, field)
        assert a.tobytes() == b.tobytes(), field


FIELDS = ("outcome", "aux", "steps", "final", "kept_states", "kept_lengths", "kept_durations")


@pytest.mark.parametrize("name", ["simplest_walker", "vsw_biped"])
def test_a_walk_does_not_depend_on_its_lane(gaits, name):
    """The walks run four at a time in lockstep (vsw/dynamics/csrc/lanes.h), each lane its own step
    size and events (the biped's eight walks held, four of one phase a step): the same
    starts in another order (other lanes, other neighbours, other groupings) walk to the
    same bytes."""
    model, params, orbits = gaits[name]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    rng = np.random.default_rng(8)
    starts = state * (1 + np.geomspace(1e-3, 0.1, 201)[:, None]
                      * rng.standard_normal((201, len(state))))  # fmt: skip
    order = rng.permutation(len(starts))
    sim = simulator(load(name))
    one = sim.walk(params, starts, 15, keep=3, threads=1)
    other = sim.walk(params, starts[order], 15, keep=3, threads=1)
    assert len(set(one.steps)) >= 3  # walks end at different steps: lanes refill
    for field in FIELDS:
        assert getattr(one, field)[order].tobytes() == getattr(other, field).tobytes(), field


@pytest.mark.parametrize("name", keys())
def test_lane_functions_are_the_scalar_ones_bit_for_bit(name):
    """Every model's flows and guard sets in lanes (derive/sim_codegen.py's twins, sin and
    cos fused, trig only on live lanes) against the scalar functions, bit for bit, at 64
    random states a phase and three masks of live lanes: the batch's claim that a lane's
    walk is the scalar integrator's rests on it (and on libm's sincos returning sin's and
    cos's values, which this checks on the machine at hand)."""
    import ctypes

    model = load(name)
    lib = simulator(model).library()
    assert lib is not None
    sizes = (ctypes.c_longlong * 4)()
    lib.vsw_batch_sizes(sizes)
    nx, n_phases = sizes[1], sizes[2]
    params = np.array(model.parameters(), dtype=float)
    states = np.random.default_rng(12).uniform(-1.5, 1.5, (64, nx))
    spec = model.spec
    watched = [sum(e["source"] == ph["name"] for e in spec["events"]) + len(ph["failures"])
               + len(ph.get("start_failures", ())) for ph in spec["phases"]]  # fmt: skip
    row = nx + max(watched)  # a state's row: the flow, then VSW_MAX_WATCH guards
    dbl = ctypes.POINTER(ctypes.c_double)
    compared = 0
    for phase in range(n_phases):
        for live in (0b1111, 0b0101, 0b1000):
            scalar, lanes = np.full((64, row), 7.0), np.full((64, row), 7.0)
            lib.vsw_batch_lanes_check(ctypes.c_int(phase), params.ctypes.data_as(dbl),
                                      states.ctypes.data_as(dbl), ctypes.c_longlong(64),
                                      ctypes.c_int(live), scalar.ctypes.data_as(dbl),
                                      lanes.ctypes.data_as(dbl))  # fmt: skip
            on = np.array([(live >> (i % 4)) & 1 for i in range(64)], dtype=bool)
            written = lanes[on] != 7.0
            assert written[:, :nx].all()
            assert scalar[on][written].tobytes() == lanes[on][written].tobytes()
            assert (lanes[~on] == 7.0).all()
            compared += int(written.sum())
    assert compared > 0


def test_step_phases_is_the_batch_walk_of_one_step(gaits):
    """`step_phases` runs the batch's integrator on one walk (the other three lanes empty):
    the same state, to the bit, as the walk of one step from each start among others."""
    from vsw.dynamics.hybrid import ATOL, RTOL

    assert RTOL == ATOL
    model, params, orbits = gaits["vsw_biped"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = state * (1 + 0.05 * np.random.default_rng(9).standard_normal((9, len(state))))
    sim = simulator(load("vsw_biped"))
    walked = sim.walk(params, starts, 1, keep=1, threads=1, tolerance=RTOL)
    completed = 0
    for k, start in enumerate(starts):
        one = sim.step_phases(params, start)
        assert (one.ended == "completed") == (walked.outcome[k] == WALKED)
        assert one.state.tobytes() == walked.final[k].tobytes()
        if one.ended == "completed":
            completed += 1
            assert sum(one.durations) == walked.kept_durations[k, 0]
            assert one.step_length == walked.kept_lengths[k, 0]
    assert completed >= 5


def _built(key: str, name: str, flags: list[str], lanes: int = 4):
    """The batch simulator of ``key`` built with these flags and lane count alone."""
    from vsw.dynamics.batch import BatchSimulator

    sim = BatchSimulator(load(key))
    sim.use_build(f"#define VSW_LANES {lanes}\n".encode() + sim.c_source(), f"{key}_sim_{name}",
                  (flags,))  # fmt: skip
    return sim


def test_the_portable_build_walks_the_same(gaits):
    """The library's last flag set (-O2 without -march=native: the lanes' vector type
    lowered to SSE2, libm's sines), built with two lanes instead of four, walks to the same
    bytes as the native build with libm's sines in four lanes:
    neither the flags nor the lane count change a walk."""
    from vsw.dynamics.batch import _LIBM_FLAGS, _PORTABLE_FLAGS

    model, params, orbits = gaits["vsw_biped"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = state * (1 + 0.1 * np.random.default_rng(10).standard_normal((60, len(state))))
    native = _built("vsw_biped", "libm", _LIBM_FLAGS)
    portable = _built("vsw_biped", "portable", _PORTABLE_FLAGS, lanes=2)
    one = native.walk(params, starts, 10, keep=2, threads=1)
    two = portable.walk(params, starts, 10, keep=2, threads=1)
    for field in FIELDS:
        assert getattr(one, field).tobytes() == getattr(two, field).tobytes(), field


def _has_avx2() -> bool:
    try:
        return " avx2 " in Path("/proc/cpuinfo").read_text().replace("\n", " ")
    except OSError:
        return False


def _vector_sines():
    """The library in use, skipping where it does not take libmvec's sines; on a glibc
    x86-64 machine with AVX2 it must."""
    from vsw.dynamics.batch import _HAS_LIBMVEC

    fast = simulator(load("vsw_biped"))
    assert fast.library() is not None, fast.build_error
    if _HAS_LIBMVEC and _has_avx2():
        assert fast._lib.vsw_batch_vector_sines() == 1
    if not fast._lib.vsw_batch_vector_sines():
        pytest.skip("the batch simulator takes libm's sines here (no AVX2 or no libmvec)")
    return fast


# Eight lanes (one more build of the biped's library) in the slow tier: two stand for a
# count other than four here.
@pytest.mark.parametrize("lanes", [2, pytest.param(8, marks=pytest.mark.slow)])
def test_the_lane_count_changes_no_walk(gaits, lanes):
    """The vector build (libmvec's sines, AVX2) built with two and eight lanes walks to the
    same bytes as the four lanes of the library in use: the vector sines are taken four at
    a time whatever the lane count."""
    from vsw.dynamics.batch import _VECTOR_FLAGS

    fast = _vector_sines()
    model, params, orbits = gaits["vsw_biped"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = state * (1 + 0.1 * np.random.default_rng(12).standard_normal((60, len(state))))
    one = fast.walk(params, starts, 10, keep=2, threads=1)
    other = _built("vsw_biped", f"lanes{lanes}", _VECTOR_FLAGS, lanes=lanes)
    two = other.walk(params, starts, 10, keep=2, threads=1)
    for field in FIELDS:
        assert getattr(one, field).tobytes() == getattr(two, field).tobytes(), field


# The biped's libm build is the portable test's too; the other two models' (a build each)
# in the slow tier.
@pytest.mark.parametrize(
    "key",
    [
        pytest.param("simplest_walker", marks=pytest.mark.slow),
        pytest.param("compass_gait", marks=pytest.mark.slow),
        "vsw_biped",
    ],
)
def test_vector_sines_walk_as_libm_does(gaits, key):
    """The vector build's sines and cosines (glibc's libmvec where the CPU has AVX2,
    vsw/dynamics/csrc/lanes.h) against libm's (the native build without it): the same outcomes and
    steps on 200 starts around the gait, section states within 1e-9 (relative) after 10 steps
    (the tolerance the SciPy route is held to): a few ulp in each sine move a walk by
    about the integrator's own rounding."""
    from vsw.dynamics.batch import _LIBM_FLAGS

    _vector_sines()
    model, params, orbits = gaits[key]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = state * (1 + 0.02 * np.random.default_rng(11).standard_normal((200, len(state))))
    if model.spec.get("section"):
        starts = np.column_stack(model.module.section_completion(*params, *starts.T))
    vector = simulator(load(key)).walk(params, starts, 10, threads=1)
    libm = _built(key, "libm", _LIBM_FLAGS).walk(params, starts, 10, threads=1)
    assert np.array_equal(vector.outcome, libm.outcome)
    assert np.array_equal(vector.steps, libm.steps)
    scale = np.maximum(1.0, np.abs(libm.final))
    assert np.nanmax(np.abs(vector.final - libm.final) / scale) <= 1e-9


def test_kept_steps_are_the_last_ones_in_order(gaits):
    model, params, orbits = gaits["simplest_walker"]
    stable = next(o for o in orbits if o.stable)
    state = np.array([stable.state[k] for k in (*model.coordinates, *model.rates)])
    start = state * (1 + 1e-3)
    sim = simulator(load("simplest_walker"))
    long = sim.walk(params, start[None], 7, converge_tol=0, period_tol=0, keep=7)
    short = sim.walk(params, start[None], 7, converge_tol=0, period_tol=0, keep=3)
    assert np.array_equal(long.kept_states[0, 4:], short.kept_states[0])
    assert np.array_equal(short.kept_states[0, -1], short.final[0])
    few = sim.walk(params, start[None], 2, converge_tol=0, period_tol=0, keep=4)
    assert np.array_equal(few.kept_states[0, :2], long.kept_states[0, :2])
    assert np.all(np.isnan(few.kept_states[0, 2:]))


@pytest.mark.slow
def test_period_two_walks_are_classified(gaits):
    """Past the flip at gamma = 0.015089 the simplest walker settles on a period-two gait
    (Garcia et al. 1998, Fig. 4): a walk from near the unstable period-one gait is
    classified period-2, its two states apart."""
    model = load("simplest_walker")
    params = model.parameters({"gamma": 0.016})
    orbits = model.fixed_points(params)
    # Garcia's long gait: the longer of the two shortest steps (the search also finds
    # gaits whose swing leg swings back and forth, periods above 9)
    long_gait = sorted(orbits, key=lambda o: o.period)[1]
    state = np.array([long_gait.state[k] for k in (*model.coordinates, *model.rates)])
    sim = simulator(load("simplest_walker"))
    walk = sim.walk(params, (state * (1 + 1e-4))[None], 400, target=state, keep=2)
    assert walk.labels() == ["period-2"]
    a, b = walk.kept_states[0]
    assert np.max(np.abs(a - b)) > 1e-3


def test_scipy_fallback_without_a_compiler(gaits, monkeypatch):
    model, params, orbits = gaits["rimless_wheel"]
    state = np.array([orbits[0].state[k] for k in (*model.coordinates, *model.rates)])
    starts = np.tile(state, (6, 1))
    starts[:, 1] *= np.linspace(0.05, 2.0, 6)  # from rolling back to walking
    compiled = simulator(load("rimless_wheel")).walk(params, starts, 20, target=state)
    monkeypatch.setenv("VSW_KERNELS", "0")
    from vsw.dynamics.batch import BatchSimulator

    fallback = BatchSimulator(model)
    slow = fallback.walk(params, starts, 20, target=state)
    assert fallback.build_error == "VSW_KERNELS=0" and slow.route == "SciPy (VSW_KERNELS=0)"
    assert compiled.route == "compiled"
    assert slow.labels() == compiled.labels()
    assert np.array_equal(slow.steps, compiled.steps)
    assert np.any(compiled.outcome == CONVERGED) and np.any(compiled.outcome == FELL)


def test_bad_shapes_are_one_line_errors(gaits):
    from vsw.runtime.errors import VswInputError

    _, params, _ = gaits["compass_gait"]
    sim = simulator(load("compass_gait"))
    with pytest.raises(VswInputError, match=r"shape \(N, 4\)"):
        sim.walk(params, np.zeros((4, 3)), 2)
    with pytest.raises(VswInputError, match="6 values"):
        sim.walk(np.zeros((3, 4)), np.zeros((3, 4)), 2)
    with pytest.raises(VswInputError, match="4 components"):
        sim.walk(params, np.zeros((3, 4)), 2, target=[0.0, 1.0])


def test_sin_cos_fusion_keeps_each_call_on_its_operand():
    """The lanes' sine and cosine of one operand come from one sincos only while the
    operand is unchanged between them (derive/sim_codegen.py's _fused_sin_cos)."""
    from derive.sim_codegen import _fused_sin_cos

    pair = ["    a1=vsw_lanes_sin(a0, live);", "    a2=(a1*a1);", "    a3=vsw_lanes_cos(a0, live);"]
    fused = _fused_sin_cos(pair)
    assert fused[0] == "    vsw_lanes vsw_sc0_sin, vsw_sc0_cos;"
    assert fused[1] == ("    vsw_lanes_sincos(a0, live, &vsw_sc0_sin, &vsw_sc0_cos);\n"
                        "    a1=vsw_sc0_sin;")  # fmt: skip
    assert fused[2:] == ["    a2=(a1*a1);", "    a3=vsw_sc0_cos;"]
    overwritten = ["    a0=vsw_lanes_sin(a0, live);", "    a1=vsw_lanes_cos(a0, live);"]
    assert _fused_sin_cos(overwritten) == overwritten
    changed = [
        "    a1=vsw_lanes_sin(a0, live);",
        "    a0=(a0+a1);",
        "    a2=vsw_lanes_cos(a0, live);",
    ]
    assert _fused_sin_cos(changed) == changed


def test_the_walks_are_named_by_their_outcome():
    """labels() and ended() name every walk by its outcome code and aux (as the batch
    simulator's C writes them: vsw_batch_simulate; a negative aux as Python indexes), in
    the walks' order, empty for no walks."""
    from vsw.dynamics.batch import PERIODIC, STALLED, BatchResult

    rng = np.random.default_rng(3)
    outcome = rng.integers(0, 5, 500)
    aux = np.where(outcome == FELL, rng.integers(-2, 2, 500),
                   np.where(outcome == PERIODIC, rng.integers(2, 9, 500), 0))  # fmt: skip
    empty = np.zeros((0, 2))
    result = BatchResult(outcome, aux, np.zeros(500, int), np.zeros((500, 2)), empty, empty,
                         empty, failures=("fell-backward", "lift-off"))  # fmt: skip
    expected_labels, expected_ended = [], []
    for code, k in zip(outcome, aux):
        label = {CONVERGED: "converged", FELL: "fell", PERIODIC: f"period-{k}"}.get(code, "other")
        expected_labels.append(label)
        ending = ("fell-backward", "lift-off")[k] if code == FELL else label
        expected_ended.append({STALLED: "stalled", WALKED: "walked"}.get(code, ending))
    assert result.labels() == expected_labels and result.ended() == expected_ended
    assert {"converged", "fell", "other", "period-2"} <= set(expected_labels)
    assert {"lift-off", "stalled", "walked"} <= set(expected_ended)
    assert {-2, -1} <= set(aux[outcome == FELL].tolist())  # an index from the end, as Python's
    none = BatchResult(outcome[:0], aux[:0], np.zeros(0, int), empty, empty, empty, empty,
                       failures=())  # fmt: skip
    assert none.labels() == [] and none.ended() == []
