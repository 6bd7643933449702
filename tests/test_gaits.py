"""The gait search (vsw.gaits.search): complete within its box, and the reason when there is none.

The reference gaits of the VSW biped come from outside this code: an independent
re-implementation of the model (its own sympy derivation and SciPy simulator) found gaits
at these parameter sets that the earlier search (Newton from a dozen pushes of one start)
missed; their largest |eigenvalue| are the numbers below.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math

import numpy as np
import pytest

from vsw.cli import main
from vsw.gaits import search as gaits
from vsw.gaits import search_cache
from vsw.models import load
from vsw.runtime.errors import CacheWarning

pytest.importorskip("casadi")

# (beta, theta_II, mu, b/l) -> largest |eigenvalue| of the gaits the independent search found
INDEPENDENT = [
    ((0.8, 0.1, 0.3, 0.3), (2.3081, 10.45)),
    ((0.8, 0.1, 1e-4, 0.3), (2.869,)),
    ((0.8, 0.1, 1e-3, 0.3), (2.867,)),
    ((0.85, 0.05, 0.3, 0.3), (3.779,)),
    ((0.85, 0.05, 1.0, 0.3), (3.394,)),
    ((0.8, -0.2, 0.3, 0.3), (635.8,)),
    ((0.99, -0.2, 0.3, 0.3), (14.09,)),
]


def biped_params(values):
    m = load("vsw_biped")
    return m, m.parameters(dict(zip(("beta", "theta_II", "mu", "b_over_l"), values)))


@pytest.mark.parametrize("values, expected", INDEPENDENT, ids=[str(v) for v, _ in INDEPENDENT])
def test_the_search_finds_every_gait_an_independent_search_found(values, expected):
    m, params = biped_params(values)
    found = m.search_gaits(params)
    assert found.complete and found.route == "compiled"
    largest = [g.max_abs_eigenvalue for g in found.gaits]
    for value in expected:
        assert any(abs(v - value) <= 5e-4 * value for v in largest), (value, largest)
    for g in found.gaits:  # each confirmed: the boundary-value solver's, simulated back
        assert g.residual <= 1e-9 and all(d > 0 for d in g.durations)


@pytest.mark.slow
def test_a_finer_scan_finds_no_gait_the_search_misses():
    """At the set with the most delicate gaits (|eigenvalue| 658 and 1394, reached only from
    bands about 0.01 wide in the rates), a scan 1.5 times finer along every axis (3.4 times
    the cells) finds the same gaits. (Twice as fine at every set of INDEPENDENT and at the
    passive walkers' defaults, benchmark case 12: no gait with max |eigenvalue| below 100
    missed anywhere; two very unstable ones, 778 and 874, added at two of the sets.)"""
    m, params = biped_params((0.8, 0.1, 1e-4, 0.3))
    default = m.search_gaits(params)
    finer = gaits.search(m, params, cells=92**3)
    assert finer.points == {"theta": 92, "theta_dot": 92, "psi_dot": 92}
    assert len(default.gaits) == len(finer.gaits) == 4
    for a, b in zip(default.gaits, finer.gaits):
        x = np.array(list(a.state.values()))
        y = np.array(list(b.state.values()))
        np.testing.assert_allclose(x, y, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("name", ["rimless_wheel", "ile", "tle"])
def test_twice_as_fine_finds_the_same_gaits_in_one_dimension(name):
    """(In two and three dimensions the same check is benchmark case 12: 40 s for the
    simplest walker, minutes for the biped's sets; the finer 3-D scan above stands for it
    here.)"""
    m = load(name)
    params = m.parameters({})
    default = m.search_gaits(params)
    dims = len(m.spec["search"])
    finer = gaits.search(m, params, cells=(2 * gaits.SCAN_POINTS[dims]) ** dims)
    states = [sorted(tuple(round(v, 8) for v in g.state.values()) for g in s.gaits)
              for s in (default, finer)]  # fmt: skip
    assert states[0] == states[1] and states[0]


@pytest.mark.slow  # a search of every passive model's section at its defaults
def test_the_kept_gaits_are_the_searchs():
    """tests/data/gaits.json, which the fixtures that walk from a model's gait read instead
    of searching (tests.conftest.committed_gaits), is what the search finds now
    (tests/data/make_gaits.py searches again): every passive model, its defaults, and its
    gaits in the search's order, states and periods to 1e-9, the largest |eigenvalue| to
    1e-6, each stable or not as found."""
    from tests.conftest import GAITS_PATH
    from tests.data.make_gaits import every_model

    kept = json.loads(GAITS_PATH.read_text())["models"]
    found = every_model()["models"]
    again = "python tests/data/make_gaits.py"
    assert list(kept) == list(found), again
    for key, record in found.items():
        assert kept[key]["parameters"] == record["parameters"], (key, again)
        assert len(kept[key]["gaits"]) == len(record["gaits"]), (key, again)
        for old, new in zip(kept[key]["gaits"], record["gaits"]):
            assert list(old["state"]) == list(new["state"])
            x, y = np.array(list(old["state"].values())), np.array(list(new["state"].values()))
            assert np.max(np.abs(x - y)) <= 1e-9 * max(1.0, np.max(np.abs(y))), (key, again)
            assert old["period"] == pytest.approx(new["period"], rel=1e-9), (key, again)
            assert old["stable"] == new["stable"], (key, again)
            assert old["max_abs_eigenvalue"] == pytest.approx(new["max_abs_eigenvalue"], rel=1e-6)
            if new["step_length"] is None:
                assert old["step_length"] is None
            else:
                assert old["step_length"] == pytest.approx(new["step_length"], rel=1e-9)


def test_the_ile_search_finds_the_closed_form_fixed_point():
    """The generic search on the ILE's engine model (not its closed forms) finds exactly
    one gait, the paper's fixed point (10), with the eigenvalue (19)."""
    import generated.ile as ile

    m = load("ile")
    params = m.parameters({"beta": 0.85, "theta_II": 0.1, "phi0": 0.6})
    found = gaits.search(m, params)
    (gait,) = found.gaits
    assert gait.state["theta_dot"] ** 2 == pytest.approx(float(ile.q_fixed(*params)), rel=1e-9)
    assert gait.max_abs_eigenvalue == pytest.approx(0.85**2 * math.cos(0.6) ** 2, rel=1e-7)


def test_no_gait_says_why(capsys):
    # The TLE with a 0.01 rad extension: the closed-form fixed point needs a pulling leg.
    argv = ["analyze", "--model", "tle", "--param", "beta=0.8", "--param", "theta_II=0",
            "--phi0", "45", "--param", "delta=0.01", "--json"]  # fmt: skip
    assert main(argv) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    assert data["fixed_points"] == []
    assert "leg_compressive" in data["reason"] and "q^f = 0.465178" in data["reason"]
    leg = next(c for c in data["closed_form"]["conditions"] if c["name"] == "leg_compressive")
    assert leg["margin"] == pytest.approx(-2182, rel=1e-3) and leg["unit"] == "m g"
    # The rimless wheel on a shallow slope: Drake's fixed point rolls back before the apex.
    assert main(["sweep", "--model", "rimless-wheel", "--over", "gamma=0.01:0.02:3",
                 "--json"]) == 0  # fmt: skip
    for point in json.loads(capsys.readouterr().out)["points"]:
        assert point["found"] is False and "fell-backward" in point["reason"]
    # A box with nothing in it: the scan's outcomes.
    assert main(["analyze", "--model", "rimless-wheel", "--search", "theta_dot=0.01:0.3",
                 "--json"]) == 0  # fmt: skip
    data = json.loads(capsys.readouterr().out)
    assert data["fixed_points"] == [] and "fell-backward" in data["reason"]
    assert data["search"]["box"] == {"theta_dot": [0.01, 0.3]}


def test_a_walk_from_an_unstable_gait_says_so(capsys):
    import json

    argv = ["simulate", "--model", "vsw-biped", "--steps", "2", "--json"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["start_from"] == "gait" and data["start_gait"]["stable"] is False
    assert "unstable gait" in data["note"] and "unstable gait" in captured.err


def test_every_gait_carries_its_failures_margins(capsys):
    import json

    assert main(["analyze", "--model", "compass-gait", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["fixed_points"]) >= 2
    for gait in data["fixed_points"]:
        names = [c["name"] for c in gait["conditions"]]
        # The failures, which end a walk, then what the model reports without enforcing it
        # (the swing foot's clearance: the compass gait scuffs, as its sources ignore).
        assert names == ["fell-backward", "fell-forward", "lift-off", "swing-foot-clearance"]
        failures = [c for c in gait["conditions"] if c["ends_walk"]]
        assert len(failures) == 3
        for c in failures:
            assert c["holds"] is True and c["margin"] > 0 and c["unit"]
        lift = gait["conditions"][2]
        assert lift["unit"] == "N"
        (clearance,) = [c for c in gait["conditions"] if not c["ends_walk"]]
        assert clearance["holds"] is False and clearance["unit"] == "m"


def sealed(data: dict) -> dict:
    """A kept search's content with its seal (file name kept, digest made to match)."""
    content = {k: v for k, v in data.items() if k != "sha256"}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return {**content, "sha256": hashlib.sha256(text.encode()).hexdigest()}


def test_a_kept_search_is_a_new_one_bit_for_bit(monkeypatch, tmp_path):
    """The scan, Newton's solutions and the confirmed gaits are kept on disk
    (vsw.gaits.search_cache.cache_file) and a later search of the same model, code and inputs reuses
    them: neither the scan nor the boundary-value solver runs again, and its gaits (their
    orbits' states too) equal a new search's bit for bit. Gaits missing (a search
    interrupted while confirming) or kept by another CasADi are confirmed again and kept
    whole; a solve that failed outside stop.supervised keeps none; a damaged file is made
    again whole; VSW_SEARCH_CACHE=0 keeps nothing."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path))
    m = load("compass_gait")
    params = m.parameters({})
    first = gaits.search(m, params, cells=20_000)
    (kept,) = (tmp_path / "searches").iterdir()
    with monkeypatch.context() as patch:  # reused: no scan and no confirmation run
        patch.setattr(gaits, "_scan", lambda *a: pytest.fail("scanned again"))
        patch.setattr(gaits, "_confirm", lambda *a: pytest.fail("confirmed again"))
        again = gaits.search(m, params, cells=20_000)
    # as JSON: the state's order and a zero's sign count too
    assert json.dumps([o.to_dict() for o in again.gaits]) == json.dumps(
        [o.to_dict() for o in first.gaits]
    )
    for a, b in zip(again.gaits, first.gaits, strict=True):
        assert (a.durations, a.eigenvalues, a.phase_states) == (b.durations, b.eigenvalues, ())
    # An orbit's phase states (none from the solver today) are not kept: no record.
    states = (np.array([[0.1, 0.2]]),)
    with_states = dataclasses.replace(first.gaits[0], phase_states=states)
    assert search_cache.confirmed_record([with_states], [], 0) is None
    assert (again.candidates, again.converged, again.outcomes, again.points) == (
        first.candidates, first.converged, first.outcomes, first.points)  # fmt: skip
    assert (again.unconfirmed, again.standing) == (first.unconfirmed, first.standing)
    assert len(first.gaits) >= 2
    record = json.loads(kept.read_text())
    # Kept without its gaits (interrupted while confirming) or by another CasADi
    # installation: confirmed again, the scan reused, the record kept whole.
    other_casadi = {**record["confirmed"], "casadi": "another"}
    for confirmed_record in (None, other_casadi):
        kept.write_text(json.dumps(sealed({**record, "confirmed": confirmed_record})))
        with monkeypatch.context() as patch:
            patch.setattr(gaits, "_scan", lambda *a: pytest.fail("scanned again"))
            confirmed = gaits.search(m, params, cells=20_000)
        assert [o.to_dict() for o in confirmed.gaits] == [o.to_dict() for o in first.gaits]
        assert json.loads(kept.read_text()) == record
    # A damaged gait (its digest made to match): nothing of the file is trusted, the whole
    # search is made again (tests/test_cache_integrity.py: every other alteration).
    damaged_gait = {**record["confirmed"], "gaits": [{"state": []}]}
    kept.write_text(json.dumps(sealed({**record, "confirmed": damaged_gait})))
    with pytest.warns(CacheWarning, match="a kept gait: not a gait's record"):
        redone = gaits.search(m, params, cells=20_000)
    assert [o.to_dict() for o in redone.gaits] == [o.to_dict() for o in first.gaits]
    assert json.loads(kept.read_text()) == record
    # Outside stop.supervised a solve CasADi failed may be a Ctrl-C: such a result is not
    # kept (the next search confirms again); under it, it is.
    failed = [{"state": {}, "period": 1.0, "reason": "rhs failed"}]
    for supervising, keeps in ((False, False), (True, True)):
        kept.write_text(json.dumps(sealed({**record, "confirmed": None})))
        with monkeypatch.context() as patch:
            patch.setattr(gaits, "_confirm", lambda *a: (first.gaits[:1], failed, 0))
            patch.setattr(gaits.stop, "supervising", lambda s=supervising: s)
            gaits.search(m, params, cells=20_000)
        assert (json.loads(kept.read_text())["confirmed"] is not None) == keeps
    kept.write_text('{"found": [[0.1')  # a file cut short
    with pytest.warns(CacheWarning, match="not JSON"):
        damaged = gaits.search(m, params, cells=20_000)
    assert [o.to_dict() for o in damaged.gaits] == [o.to_dict() for o in first.gaits]
    assert json.loads(kept.read_text())["converged"] == first.converged
    # Another input, another file; none with the cache off.
    gaits.search(m, params, cells=8_000)
    assert len(list((tmp_path / "searches").iterdir())) == 2
    monkeypatch.setenv("VSW_SEARCH_CACHE", "0")
    gaits.search(m, params, cells=5_000)
    assert len(list((tmp_path / "searches").iterdir())) == 2


def test_distinct_solutions_keep_the_first_of_each_cluster_in_order():
    """The scan's deduplication against its definition written pair by pair: a solution is
    kept unless it lies within DISTINCT * max(1, |x|) of one kept before it in every
    component."""
    rng = np.random.default_rng(3)
    centres = rng.uniform(-2.0, 2.0, (60, 3))
    solutions = np.repeat(centres, 7, axis=0) + 1e-11 * rng.standard_normal((420, 3))
    rng.shuffle(solutions)
    wanted: list[np.ndarray] = []
    for x in solutions:
        scale = gaits.DISTINCT * np.maximum(1.0, np.abs(x))
        if all(np.any(np.abs(x - other) > scale) for other in wanted):
            wanted.append(x)
    got = gaits._distinct(solutions)
    assert len(got) == len(wanted) == 60
    assert all(np.array_equal(a, b) for a, b in zip(got, wanted))
    assert gaits._distinct(np.empty((0, 3))) == []
