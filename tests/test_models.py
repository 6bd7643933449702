"""Every engine model, checked against physics its derivation did not use.

Parametrised over the generated packages (``generated.MODELS``); a package without a
``HYBRID`` descriptor is not an engine model and is skipped with that reason (the ILE keeps
its own closed-form tests until it is ported onto the engine). For each engine model:

* T + V is constant along simulated trajectories in its conservative phases (no held
  coordinate moves), and the generated energy's kinetic part is the bodies' own
  ``1/2 m v**2 + 1/2 I w**2``;
* every reset balances momentum: across an impact the whole system's angular momentum
  about the new contact is conserved (the only impulse acts there) and the kinetic energy
  lost is that of the velocity jump (Carnot); across a jump (an actuator's impulse) the
  angular momentum about the stance foot is conserved. Positions come from the generated
  ``<phase>_positions``, velocities from CasADi's derivative of them, not from the
  derivation's Jacobians;
* the fixed point of the Poincaré map iterated by simulation equals the boundary-value
  orbit (``HybridModel.periodic_orbit``) to 1e-9, and the closed form when there is one;
* numpy and CasADi evaluate every generated function alike; the compiled C library agrees
  with numpy;
* ``python -m derive --check`` fails when any file of any model is damaged.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import itertools
import shutil

import casadi as ca
import numpy as np
import pytest

import generated
from derive.__main__ import main as derive_main
from derive.__main__ import stale_report, write_atomically
from tests.conftest import committed_gaits, passive_keys
from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.ledger import energy_ledger
from vsw.gaits.search import search
from vsw.models import load

MODELS = generated.MODELS
REL_TOL = 1e-12
ORBIT_TOL = 1e-9


def engine(name: str) -> HybridModel:
    """The engine model ``name``, or a skip saying why the package is not one."""
    module = importlib.import_module(f"generated.{name}")
    if not hasattr(module, "HYBRID"):
        pytest.skip(
            f"generated/{name} has no HYBRID descriptor: not an engine model (its closed "
            "forms are tested in tests/test_generated_backends.py)"
        )
    return load(name)


def parameter_sets(m: HybridModel, count: int, seed: int) -> list[tuple[float, ...]]:
    """The defaults, then ``count - 1`` sets drawn near them, where the model should walk
    too: each parameter scaled by exp(U(-0.08, 0.08)), or moved by U(-0.02, 0.02) of its
    interval if its default is 0; kept inside its open interval."""
    rng = np.random.default_rng(seed)
    sets = [m.parameters({})]
    while len(sets) < count:
        values = {}
        for p in m.parameter_table:
            if p.default:
                value = p.default * np.exp(rng.uniform(-0.08, 0.08))
            else:
                span = p.upper - p.lower if np.isfinite(p.upper - p.lower) else 1.0
                value = rng.uniform(-0.02, 0.02) * span
            values[p.name] = value if p.lower < value < p.upper else p.default
        sets.append(m.parameters(values))
    return sets


def random_arguments(m: HybridModel, names: list[str], n: int, seed: int) -> list[np.ndarray]:
    """``n`` values of each named argument: parameters anywhere inside their open interval
    (unbounded ones within a factor e of the default), coordinates, rates, ``q``, and
    positive values for any other argument."""
    rng = np.random.default_rng(seed)
    table = {p.name: p for p in m.parameter_table}
    out = []
    for name in names:
        if name in table:
            p = table[name]
            if np.isfinite(p.lower) and np.isfinite(p.upper):
                span = p.upper - p.lower
                out.append(rng.uniform(p.lower + 0.01 * span, p.upper - 0.01 * span, n))
            else:
                out.append(p.default * np.exp(rng.uniform(-1.0, 1.0, n)))
        elif name in m.coordinates:
            out.append(rng.uniform(-0.7, 0.7, n))
        elif name in m.rates:
            out.append(rng.uniform(-3.0, 3.0, n))
        elif name == "q":  # the closed form's rate**2 on the section
            out.append(rng.uniform(0.05, 5.0, n))
        else:  # a model's own extra argument (a leg ratio, a mass, a rate): positive
            out.append(rng.uniform(0.3, 1.2, n))
    return out


def call(m: HybridModel, name: str, values: dict[str, float]):
    """A generated function evaluated with its arguments taken by name from ``values``."""
    fn = getattr(m.module, name)
    return fn(*(values[a] for a in inspect.signature(fn).parameters))


def reset_function(m: HybridModel, event: str) -> str:
    """Name of the generated reset of ``event`` (``event_<event>_reset``; before the engine
    prefixed event functions, ``<event>_reset``)."""
    for name in (f"event_{event}_reset", f"{event}_reset"):
        if hasattr(m.module, name):
            return name
    raise AssertionError(f"{m.name}: no generated reset for the event {event}")


def generated_functions(m: HybridModel) -> dict[str, object]:
    """Every public function of the model's generated package."""
    return {
        name: fn
        for name, fn in inspect.getmembers(m.module, inspect.isfunction)
        if fn.__module__ == m.module.__name__ and not name.startswith("_")
    }


def outputs(value, n: int) -> np.ndarray:
    """A generated function's numpy result as an (outputs, n) array."""
    parts = value if isinstance(value, tuple) else (value,)
    return np.array([np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in parts])


def casadi_outputs(fn, args: list[np.ndarray]) -> np.ndarray:
    """The same function built on CasADi SX symbols, evaluated point by point."""
    symbols = [ca.SX.sym(f"a{k}") for k in range(len(args))]
    value = fn(*symbols)
    parts = value if isinstance(value, tuple) else (value,)
    f = ca.Function("f", symbols, [ca.SX(ca.vertcat(*parts))])
    return np.array(f.map(len(args[0]))(*args), dtype=float)


# --- gaits (shared by several tests) ------------------------------------------------------


@functools.cache
@functools.cache
def gaits(name: str) -> list[tuple[tuple[float, ...], list]]:
    """(parameters, period-one orbits) at the defaults (the search every command makes)
    and two nearby sets (a scan of 24 points a side: the tests here check the physics
    along gaits, tests/test_gaits.py the search)."""
    m = load(name)
    if m.spec.get("powered_only"):
        pytest.skip(f"{name} walks only powered (no passive gait): tests/test_point_mass_biped.py "
                    "checks it along its powered gaits")  # fmt: skip
    defaults, *nearby = parameter_sets(m, 3, seed=12)
    coarse = 24 ** len(m.spec["search"])
    # At the defaults the kept gaits, confirmed (tests.conftest), stand for the search's.
    committed = committed_gaits(name)
    at_defaults = committed[2] if committed is not None else m.fixed_points(defaults)
    return [(defaults, at_defaults)] + [(p, search(m, p, cells=coarse).gaits) for p in nearby]


def walking_states(m: HybridModel) -> list[tuple[tuple[float, ...], np.ndarray]]:
    """Section states to simulate from: each gait, and its rates 10 % and 30 % off."""
    out = []
    for p, orbits in gaits(m.name):
        for orbit in orbits:
            x = np.array(list(orbit.state.values()))
            for factor in (1.0, 1.1, 0.7):
                out.append((p, np.concatenate([x[: m.n], factor * x[m.n :]])))
    return out


def test_every_model_walks_at_its_defaults():
    """The defaults of every engine model give at least one period-one gait (the other
    tests simulate from them)."""
    engines = [n for n in passive_keys() if hasattr(importlib.import_module(f"generated.{n}"),
                                                     "HYBRID")]  # fmt: skip
    assert engines, "no engine model is generated"
    for name in engines:
        m = load(name)
        (defaults, orbits), *_ = gaits(name)
        assert defaults == m.parameters({})
        assert orbits, f"{name}: no period-one gait at the default parameters"


# --- energy -------------------------------------------------------------------------------


def _segments(trajectory) -> list[tuple[int, np.ndarray]]:
    """(phase index, states) of each stretch between resets. A reset repeats the time with
    another state or phase; a sample repeated whole (an event's state) is dropped."""
    t, x, phase = trajectory.t, trajectory.states, trajectory.phase
    same_time = np.diff(t) == 0
    same = same_time & np.all(np.diff(x, axis=0) == 0, axis=1) & (np.diff(phase) == 0)
    keep = np.concatenate([[True], ~same])
    t, x, phase = t[keep], x[keep], phase[keep]
    cuts = np.flatnonzero((np.diff(t) == 0) | (np.diff(phase) != 0)) + 1
    bounds = [0, *cuts.tolist(), len(t)]
    return [(int(phase[a]), x[a:b]) for a, b in itertools.pairwise(bounds) if b > a]


@pytest.mark.parametrize("name", MODELS)
def test_energy_is_constant_in_conservative_phases(name):
    m = engine(name)
    if not any(phase["conservative"] for phase in m.phases):
        pytest.skip(f"{name}: every phase moves a held coordinate (actuator work)")
    checked = 0
    for p, state in walking_states(m):
        # Samples at most 0.01 apart: short phases (the TLE's) get enough of them.
        trajectory = m.simulate(p, state, steps=3, max_step=0.01)
        for k, samples in _segments(trajectory):
            phase = m.phases[k]
            if not phase["conservative"] or len(samples) < 5:
                continue
            x = samples.T
            energy = np.asarray(m.function(f"{phase['name']}_energy")(*p, *x), dtype=float)
            at_rest = np.concatenate([x[: m.n], np.zeros_like(x[m.n :])])
            potential = np.asarray(m.function(f"{phase['name']}_energy")(*p, *at_rest), dtype=float)
            scale = np.max(np.abs(energy - potential)) + np.max(np.abs(potential))
            # The phase really moves: its kinetic energy changes by a visible fraction (a
            # phase of a few samples, 0.04 time units, may not: the check needs ten).
            if len(samples) >= 10:
                assert np.ptp(energy - potential) > 1e-3 * scale
            assert np.ptp(energy) <= 1e-9 * scale, (phase["name"], np.ptp(energy) / scale)
            checked += 1
    assert checked >= 3


def _kinematics(m: HybridModel, phase: str):
    """Bodies of a phase at a state: (x, y, angle) rows, their velocities (CasADi's
    derivative of the generated positions along the rates) and (mass, inertia) rows."""
    positions = m.function(f"{phase}_positions")
    p = ca.SX.sym("p", len(m.parameter_table))
    q, u = ca.SX.sym("q", m.n), ca.SX.sym("u", m.n)
    pos = ca.vertcat(*positions(*ca.vertsplit(p), *ca.vertsplit(q), *ca.vertsplit(u)))
    f = ca.Function("kinematics", [p, q, u], [pos, ca.jtimes(pos, q, u)])

    def at(params, x):
        r, v = (np.array(a, dtype=float).reshape(-1, 3) for a in f(params, x[: m.n], x[m.n :]))
        inertia = outputs(m.function(f"{phase}_inertias")(*params, *x), 1).reshape(-1, 2)
        return r, v, inertia

    return at


def _angular_momentum(r, v, inertia, about) -> tuple[float, float]:
    """Angular momentum about a point, and the scale of its terms."""
    arm = r[:, :2] - np.asarray(about, dtype=float)
    orbital = inertia[:, 0] * (arm[:, 0] * v[:, 1] - arm[:, 1] * v[:, 0])
    spin = inertia[:, 1] * v[:, 2]
    scale = np.sum(np.abs(inertia[:, 0]) * np.hypot(*arm.T) * np.hypot(v[:, 0], v[:, 1]))
    return float(np.sum(orbital + spin)), float(scale + np.sum(np.abs(spin)))


def _kinetic(v, inertia) -> float:
    return float(0.5 * np.sum(inertia[:, 0] * (v[:, 0] ** 2 + v[:, 1] ** 2)
                              + inertia[:, 1] * v[:, 2] ** 2))  # fmt: skip


@pytest.mark.parametrize("name", MODELS)
def test_generated_energy_is_the_bodies_kinetic_plus_a_potential(name):
    """E(q, u) - E(q, 0) equals 1/2 sum m v**2 + I w**2 from the bodies' own velocities."""
    m = engine(name)
    args = random_arguments(m, [*m.spec["parameters"], *m.coordinates, *m.rates], 30, seed=4)
    points = np.array(args).T
    for phase in m.phases:
        kinematics = _kinematics(m, phase["name"])
        energy = m.function(f"{phase['name']}_energy")
        for row in points:
            p, x = tuple(row[: len(m.parameter_table)]), row[len(m.parameter_table) :]
            _, v, inertia = kinematics(p, x)
            at_rest = np.concatenate([x[: m.n], np.zeros(m.n)])
            kinetic = float(energy(*p, *x)) - float(energy(*p, *at_rest))
            assert kinetic == pytest.approx(_kinetic(v, inertia), rel=1e-12, abs=1e-14)


# --- momentum balance across resets ---------------------------------------------------------


def _reset_states(m: HybridModel) -> list[tuple[tuple[float, ...], dict, np.ndarray]]:
    """(parameters, event, state just before it) from simulated walks, each checked to be
    where the simulation applied that event's reset."""
    out = []
    for p, state in walking_states(m):
        trajectory = m.simulate(p, state, steps=2)
        segments = _segments(trajectory)
        for (k, before), (k_next, after) in itertools.pairwise(segments):
            x_minus, x_plus = before[-1], after[0]
            source, target = m.phases[k]["name"], m.phases[k_next]["name"]
            candidates = [
                e for e in m.by_source.get(source, [])
                if e["target"] == target and np.allclose(m.reset(e["name"], p, x_minus), x_plus,
                                                         rtol=1e-14, atol=1e-14)
            ]  # fmt: skip
            assert candidates, f"{m.name}: no event of {source} gives the state after"
            out.append((p, candidates[0], x_minus))
    return out


@pytest.mark.parametrize("name", MODELS)
def test_angular_momentum_is_conserved_across_every_reset(name):
    m = engine(name)
    states = _reset_states(m)
    # Every event also at random states: the balance is an identity of the reset map.
    args = random_arguments(m, [*m.spec["parameters"], *m.coordinates, *m.rates], 10, seed=9)
    for row in np.array(args).T:
        p, x = tuple(row[: len(m.parameter_table)]), row[len(m.parameter_table) :]
        # A continuous transition's balance holds only on its guard (the held coordinates
        # of both phases agree there, and nowhere else), and so does a lock's (the joint
        # is at its stop there): the walks above check them.
        states += [(p, event, x) for event in m.events
                   if event["reset"] not in ("continuous", "lock")]  # fmt: skip
    assert {e["name"] for _, e, _ in states} == {e["name"] for e in m.events}
    for p, event, x_minus in states:
        before = _kinematics(m, event["source"])(p, x_minus)
        x_plus = m.reset(event["name"], p, x_minus)
        after = _kinematics(m, event["target"])(p, x_plus)
        if event["reset"] == "impact":
            # The same bodies in the same order on both sides (the legs swap roles).
            order = list(event["bodies"])
            before = (before[0][order], before[1][order], before[2][order])
            contact = m.function(f"event_{event['name']}_contact")(*p, *x_minus)
            contact = outputs(contact, 1).ravel()
            # The configuration does not change: each body is where it was, seen from the
            # new contact (the origin of the target phase's chart).
            shifted = before[0] - np.array([*contact, 0.0])
            np.testing.assert_allclose(after[0], shifted, rtol=0, atol=1e-12)
            l_minus, scale = _angular_momentum(*before, about=contact)
            l_plus, _ = _angular_momentum(*after, about=(0.0, 0.0))
            # Carnot: a perfectly inelastic impact loses the kinetic energy of the jump,
            # where every impulse is workless: not where an actuator holds a coordinate
            # that moves after it (tests/test_torso_walker.py adds its work there).
            if m.phases[m.phase_index[event["target"]]]["conservative"]:
                jump = after[1] - before[1]
                lost = _kinetic(before[1], before[2]) - _kinetic(after[1], after[2])
                assert lost >= -1e-12 * _kinetic(before[1], before[2])
                assert lost == pytest.approx(_kinetic(jump, before[2]), rel=1e-9, abs=1e-13)
        else:
            l_minus, scale = _angular_momentum(*before, about=(0.0, 0.0))
            l_plus, _ = _angular_momentum(*after, about=(0.0, 0.0))
            if event["reset"] == "lock":  # a plastic impact inside the walker: Carnot too
                np.testing.assert_allclose(after[0], before[0], rtol=0, atol=1e-9)
                jump = after[1] - before[1]
                lost = _kinetic(before[1], before[2]) - _kinetic(after[1], after[2])
                assert lost == pytest.approx(_kinetic(jump, before[2]), rel=1e-7, abs=1e-13)
        assert abs(l_plus - l_minus) <= REL_TOL * max(scale, 1e-300), (event["name"], x_minus)


# --- fixed points ---------------------------------------------------------------------------


def _iterate(m: HybridModel, p, x: np.ndarray, slope: float, limit: int = 800) -> np.ndarray:
    """Iterate the simulated Poincaré map until the distance to its fixed point, estimated
    from the last step as |dx| slope / (1 - slope), is below 1e-11 of the state."""
    for _ in range(limit):
        result = m.step(p, x)
        assert result.ended == "completed", result.ended
        dx = float(np.max(np.abs(result.state - x)))
        x = result.state
        if dx * max(slope, 1e-3) / (1 - slope) <= 1e-11 * max(1.0, float(np.max(np.abs(x)))):
            return x
    raise AssertionError(f"{m.name}: no convergence in {limit} steps (slope {slope:.3g})")


@pytest.mark.parametrize("name", MODELS)
def test_simulated_fixed_point_equals_the_orbit_and_the_closed_form(name):
    m = engine(name)
    checked = 0
    for p, orbits in gaits(name):
        for orbit in orbits:
            x_star = np.array(list(orbit.state.values()))
            scale = max(1.0, float(np.max(np.abs(x_star))))
            # The orbit is a fixed point of the simulated map (event detection, DOP853) ...
            # An unstable orbit amplifies the integrator's own error within the step by up
            # to its largest eigenvalue (the VSW biped has gaits with |lambda| ~ 1e3); a
            # stable one is checked at ORBIT_TOL itself.
            growth = max(1.0, orbit.max_abs_eigenvalue)
            np.testing.assert_allclose(m.step(p, x_star).state, x_star, rtol=0,
                                       atol=ORBIT_TOL * scale * growth)  # fmt: skip
            slope = orbit.max_abs_eigenvalue
            if slope < 0.95:  # ... and where it attracts, the map's iterates converge to it
                start = np.concatenate([x_star[: m.n], 1.02 * x_star[m.n :]])
                np.testing.assert_allclose(_iterate(m, p, start, slope), x_star, rtol=0,
                                           atol=ORBIT_TOL * scale)  # fmt: skip
            if m.spec["closed_form"]:
                values = dict(zip(m.spec["parameters"], p))
                rate = x_star[m.n]
                assert rate**2 == pytest.approx(float(call(m, "q_fixed", values)), rel=ORBIT_TOL)
                if hasattr(m.module, "section_angle"):
                    angle = float(call(m, "section_angle", values))
                    assert x_star[0] == pytest.approx(angle, rel=ORBIT_TOL, abs=ORBIT_TOL)
                # The Poincaré map's eigenvalues: the closed form's slope, and zeros (the
                # section fixes the configuration).
                lam = float(call(m, "eigenvalue", values))
                assert slope == pytest.approx(lam, rel=1e-8)
            checked += 1
    assert checked >= 1  # the defaults' gait at least (test_every_model_walks_at_its_defaults)


@pytest.mark.parametrize("name", MODELS)
def test_orbit_eigenvalues_equal_the_poincare_maps(name):
    """The orbit's eigenvalues (implicit function theorem on the boundary-value residual's
    Jacobian) equal those of the Poincaré map's own derivative (each phase's end time by a
    rootfinder on its guard, CasADi derivatives through it): two routes to one matrix."""
    m = engine(name)
    checked = 0
    for p, orbits in gaits(name):
        for orbit in orbits:
            if orbit.max_abs_eigenvalue > 100:
                continue  # one simulated step from it is too sensitive to rounding
            checked += 1
            x_star = np.array(list(orbit.state.values()))
            direct = np.array(m.eigenvalues(p, x_star))
            ours = np.array(orbit.eigenvalues)
            scale = max(1.0, float(np.max(np.abs(direct))))
            np.testing.assert_allclose(np.sort_complex(ours), np.sort_complex(direct), rtol=0,
                                       atol=1e-7 * scale)  # fmt: skip
    assert checked >= 1


@pytest.mark.parametrize("name", MODELS)
def test_closed_form_stride_map_equals_one_simulated_step(name):
    m = engine(name)
    if not m.spec["closed_form"]:
        pytest.skip(f"{name}: no closed-form stride map")
    checked = 0
    for p, orbits in gaits(name):
        values = dict(zip(m.spec["parameters"], p))
        for orbit in orbits:
            angle, rate = orbit.state[m.coordinates[0]], orbit.state[m.rates[0]]
            q_f = float(call(m, "q_fixed", values))
            # Slower and faster than the gait: a walk may end (too slow to pass the apex,
            # so fast the foot lifts off), but by one of the model's failures.
            for q in (0.97 * q_f, 1.03 * q_f, 1.1 * q_f):
                result = m.step(p, np.array([angle, np.sign(rate) * np.sqrt(q)]))
                if result.ended != "completed":
                    assert result.ended in {f[0] for phase in m.phases for f in phase["failures"]}
                    continue
                q_next = float(call(m, "stride_map", {**values, "q": q}))
                assert result.state[1] ** 2 == pytest.approx(q_next, rel=1e-10)
                checked += 1
    assert checked >= 2


# --- numpy, CasADi and C ----------------------------------------------------------------------


@pytest.mark.parametrize("name", MODELS)
def test_numpy_and_casadi_agree_on_every_generated_function(name):
    m = engine(name)
    functions = generated_functions(m)
    assert {f"{phase['name']}_accelerations" for phase in m.phases} <= set(functions)
    for fname, fn in functions.items():
        names = list(inspect.signature(fn).parameters)
        args = random_arguments(m, names, 40, seed=len(fname))
        expected = outputs(fn(*args), 40)
        got = casadi_outputs(fn, args)
        assert got.shape == expected.shape, fname
        floor = 1e-14 * max(1.0, float(np.max(np.abs(expected))))
        np.testing.assert_allclose(got, expected, rtol=REL_TOL, atol=floor, err_msg=fname)


@pytest.fixture(scope="module")
def c_libraries(tmp_path_factory):
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler")
    from vsw.dynamics.ccode import CLibrary

    return lambda name: CLibrary.build(tmp_path_factory.mktemp(f"c_{name}"), model=name)


@pytest.mark.parametrize("name", MODELS)
def test_compiled_c_agrees_with_numpy(name, c_libraries):
    m = engine(name)
    lib = c_libraries(name)
    exported = set(lib.functions())
    required = {f"{phase['name']}_accelerations" for phase in m.phases}
    required |= {reset_function(m, event["name"]) for event in m.events}
    if m.spec["closed_form"]:
        required |= {"stride_map", "q_fixed", "eigenvalue"}
    assert required <= exported, (
        f"{name}'s C library lacks {sorted(required - exported)}: declare them in its "
        "Derivation.c_exports (derive.engine.c_exports)"
    )
    for fname in sorted(exported):
        fn = getattr(m.module, fname, None)
        if fn is None:  # composed from several functions (CExport.build): its own tests
            continue
        names = list(lib.arguments(fname))
        assert names == list(inspect.signature(fn).parameters), fname
        args = random_arguments(m, names, 25, seed=3)
        expected = outputs(fn(*args), 25)
        got = np.array([lib.call(fname, *row) for row in np.array(args).T]).T
        floor = 1e-14 * max(1.0, float(np.max(np.abs(expected))))
        np.testing.assert_allclose(got, expected, rtol=REL_TOL, atol=floor, err_msg=fname)


# --- python -m derive --check ---------------------------------------------------------------


@pytest.fixture
def rendered(rendered_tree) -> dict[str, str]:
    return rendered_tree


def test_derive_renders_every_model(rendered):
    from derive.models import MODELS as DERIVED

    packages = {path.split("/")[0] for path in rendered if "/" in path}
    assert packages == set(DERIVED) == set(MODELS)


def _damage(path, how: str) -> None:
    if how == "missing":
        path.unlink()
    else:
        text = path.read_text()
        path.write_text(text[: len(text) // 2] + "x" + text[len(text) // 2 :])


@pytest.mark.parametrize("name", MODELS)
def test_check_fails_on_damage_to_any_file_of_the_model(name, rendered, tmp_path):
    """Each file of the model's package, edited or removed in a copy: the comparison
    ``--check`` makes reports it."""
    files = sorted(path for path in rendered if path.startswith(f"{name}/"))
    assert files
    out = tmp_path / "generated"
    write_atomically(rendered, out)
    assert stale_report(rendered, out) == []
    for path in files:
        for how in ("edit", "missing"):
            _damage(out / path, how)
            report = "\n".join(stale_report(rendered, out))
            assert f"generated/{path}" in report, (path, how)
            (out / path).write_text(rendered[path])


def test_check_command_fails_for_damage_in_every_model(cached_derivation, tmp_path, capsys):
    rendered = cached_derivation
    """One real ``python -m derive --check`` on a copy with every model damaged names each."""
    out = tmp_path / "generated"
    write_atomically(rendered, out)
    for name in MODELS:
        _damage(out / name / "__init__.py", "missing")  # one line each in the report
    capsys.readouterr()
    assert derive_main(["--check", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    for name in MODELS:
        assert f"generated/{name}/__init__.py" in err, name


@pytest.mark.parametrize("name", MODELS)
def test_every_gaits_energy_ledger_balances(name):
    """Issue 26's ledger (vsw/dynamics/ledger.py) over a step of every gait at the defaults: in the
    phases, the work of gravity and of each actuator (quadrature of its power) accounts
    for the kinetic energy's change to 1e-9 of the largest term (the balance; the events'
    actuator work is a remainder, so it checks the phases only); at an impact the ground's
    work (Kelvin: impulse times the contact's mean velocity) is a loss, and where no
    actuator holds a moving coordinate through it, it equals both the kinetic energy lost
    and Carnot's loss from the bodies' velocity jumps: three computations of one number."""
    m = engine(name)
    (params, orbits), *_ = gaits(name)
    for orbit in orbits:
        ledger = energy_ledger(m, params, orbit)
        assert abs(ledger["balance_relative"]) < 1e-9, (name, ledger["totals"])
        # Periodic as simulated (the step's integration against the orbit solver's).
        assert abs(ledger["totals"]["kinetic_gained"]) < 1e-7 * ledger["scale"]
        for event in ledger["events"]:
            if event["reset"] not in ("impact", "lock"):
                continue
            assert event["loss"] > 0.0, event
            if not event["actuators"]:
                assert abs(event["actuator_work"]) <= 1e-9 * event["loss"], event
                assert event["velocity_jump_energy"] == pytest.approx(event["loss"], rel=1e-9)
