"""``vsw sweep``'s attractor labels: a period only once the iterated map has settled.

The truth for the simplest walker's cascade comes from outside the code under test: the
flips Garcia, Chatterjee, Ruina & Coleman (1998, "The simplest walking model: stability,
complexity, and scaling", J. Biomech. Eng. 120) report (the first period doubling near
gamma = 0.0151, the cascade to chaos near 0.019), the flips ``vsw continue`` locates along
the branches (pseudo-arclength on the orbit residual, not the iterated map:
:data:`FLIPS`), and a long walk of the batch-simulated map checked here with a tight
tolerance of the test's own (:func:`long_walk_period`).
"""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

from vsw.cli import main
from vsw.studies.sweeps import settled_period

pytest.importorskip("casadi")

FLIPS = (0.0150884, 0.0176694, 0.0181601, 0.0182648)
"""The flips of the period-1, -2, -4 and -8 branches, as ``vsw continue --model
simplest-walker --over gamma=0.009:0.0195`` locates them (Garcia et al.: 0.0151 for the
first)."""

CASCADE = ["sweep", "--model", "simplest-walker", "--over", "gamma=0.009:0.0195:43"]


def expected_period(gamma: float) -> int | None:
    """The period of the attractor at ``gamma`` from the flips: 1, 2, 4, 8 between them;
    None past the period-8 flip (period 16 and on, then chaos: no label claimed)."""
    for k, flip in enumerate(FLIPS):
        if gamma < flip:
            return 2**k
    return None


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def cascade():
    """The sweep a user ran with ``--plot``, as JSON: the defaults of the iteration
    (--keep 32 as --plot sets it, --transient 100, --max-steps 2000); without the figure,
    whose special points' continuation would triple the time (the figure is drawn from
    this record below)."""
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert main([*CASCADE, "--keep", "32", "--json"]) == 0
    return json.loads(buffer.getvalue())


def long_walk_period(gamma: float, state: dict[str, float], steps: int = 20_000) -> int | None:
    """The period of the map walked ``steps`` steps from the gait ``state`` (moved by
    1e-6), by the test's own check: the smallest k with the last 256 states repeating at
    lag k to 1e-11 (relative) while every shorter lag is at least 1e-6 apart."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    model = load("simplest_walker")
    params = np.array(model.parameters({"gamma": gamma}))
    start = np.array(list(state.values()))[None] * (1 + 1e-6)
    walks = simulator(model).walk(params, start, steps, converge_tol=0.0, period_tol=0.0,
                                  keep=256, threads=1)  # fmt: skip
    assert walks.ended() == ["walked"]
    kept = walks.kept_states[0]
    gaps = [np.max(np.abs(kept[k:] - kept[:-k])) for k in range(1, 33)]
    for k, gap in enumerate(gaps, 1):
        if gap <= 1e-11:
            return k if all(g >= 1e-6 for g in gaps[: k - 1]) else None
    return None


def test_settled_period_needs_two_cycles_and_distinct_points():
    """Synthetic orbits whose period is known by construction."""
    cycle = np.array([[0.1, 1.0], [0.3, 1.2], [0.2, 0.9]])
    assert settled_period(np.tile(cycle, (4, 1))) == 3
    assert settled_period(np.tile(cycle, (2, 1))[:5]) is None  # fewer than two cycles
    assert settled_period(np.full((8, 2), 0.25)) == 1
    # A period-2 orbit approached with multiplier mu = -0.99 per two steps: at lag 4 the
    # deviation has shrunk by 1 - mu^2 = 0.02, at lag 2 only by 1 - mu = 1.99.
    n = np.arange(32)
    offset = 2e-7 * (-0.99) ** (n // 2)
    slow = np.column_stack([np.where(n % 2, 0.4, 0.5) + offset, np.full(32, 0.3)])
    assert np.max(np.abs(slow[4:] - slow[:-4])) < 1e-8 < np.max(np.abs(slow[2:] - slow[:-2]))
    assert settled_period(slow) is None  # not period 4: not settled
    # The logistic map at r = 4 (chaos) repeats at no lag.
    x = [0.2]
    for _ in range(63):
        x.append(4 * x[-1] * (1 - x[-1]))
    assert settled_period(np.array(x)[:, None]) is None


def test_cascade_labels_from_the_default_settings(cascade):
    """Every label of the user's sweep is the attractor's: period 1 below the first flip,
    2 up to 0.0176694 (0.0175 included), 4, then 8 at 0.01825; past the period-8 flip no
    period is claimed; the two values the long walk checks agree."""
    assert (cascade["transient"], cascade["keep"], cascade["max_steps"]) == (100, 32, 2000)
    periods = {}
    for point in cascade["points"]:
        gamma, attractor = point["gamma"], point["attractor"]
        if attractor is None:  # the period-one gait is stable: it is the attractor
            assert point["stable"] is True
            periods[gamma] = 1
            continue
        if attractor["ended"] != "completed":
            assert gamma > 0.019 and attractor["settled"] is False  # Garcia: chaos, then falls
            continue
        assert attractor["settled"] is (attractor["period"] is not None)
        periods[gamma] = attractor["period"]
        want = expected_period(gamma)
        if want is not None:
            assert attractor["period"] == want, (gamma, attractor["period"])
        else:
            assert attractor["period"] is None or attractor["period"] >= 16, gamma
            assert attractor["steps_walked"] == 2000
    near = {round(g, 6): p for g, p in periods.items()}
    assert near[0.015] == 1 and near[0.01525] == 2 and near[0.0175] == 2
    assert near[0.01775] == 4 and near[0.01825] == 8
    by_gamma = {round(p["gamma"], 6): p for p in cascade["points"]}
    for gamma in (0.0175, 0.01825):
        assert long_walk_period(gamma, by_gamma[gamma]["state"]) == near[gamma]


def test_brute_force_cascade_labels(capsys, cascade):
    """The brute-force diagram (every value from its own gait, one batch) settles on the
    same periods by the same rule (started from the sweep's first gait, no search)."""
    state = [f"--state={k}={v!r}" for k, v in cascade["points"][0]["state"].items()]
    code, out, err = run(capsys, [*CASCADE, "--brute-force", *state, "--json"])
    assert code == 0, err
    for point in json.loads(out)["points"]:
        gamma, attractor = point["gamma"], point["attractor"]
        want = expected_period(gamma)
        if want is not None:
            assert attractor["settled"] and attractor["period"] == want, gamma
        else:
            assert attractor["period"] is None or attractor["period"] >= 16, gamma


def test_cascade_text_and_figure_say_not_settled(capsys, tmp_path, cascade):
    """The chaotic values are 'not settled after 2000 steps' in the text output and a
    legend entry of their own in the figure."""
    from vsw.cli.sweep import attractor_label
    from vsw.plots.diagrams import bifurcation_plot
    from vsw.plots.figures import save_figure

    labels = {round(p["gamma"], 6): attractor_label(p["attractor"])
              for p in cascade["points"] if p["attractor"]}  # fmt: skip
    assert labels[0.0175] == "period-2" and labels[0.01825] == "period-8"
    assert labels[0.0185] == "not settled after 2000 steps"
    units = {"length": "l", "time": "sqrt(l/g)"}
    figure = bifurcation_plot(cascade, "step_length", units, "simplest walker")
    texts = [t.get_text() for t in figure.legends[0].get_texts()]
    assert "iterated map, not settled after 2000 steps" in texts
    assert "iterated map, settled (last steps)" in texts
    first = save_figure(figure, tmp_path / "a.svg").read_bytes()
    again = bifurcation_plot(cascade, "step_length", units, "simplest walker")
    assert save_figure(again, tmp_path / "b.svg").read_bytes() == first


LONG_GAIT_0175 = {"theta": -0.248886, "phi": -0.497772, "theta_dot": 0.241636,
                  "phi_dot": 0.0293229}  # fmt: skip
"""Garcia's long gait at gamma = 0.0175 to six digits (``vsw sweep`` continued from 0.009
prints it): a start from which the period-one gait is solved."""


def test_a_short_walk_is_not_settled(capsys):
    """Eight steps from the long gait at gamma = 0.0175 (its period-2 attractor is slow to
    reach) are not labelled with a period: 'not settled after 8 steps', in JSON and text."""
    state = [f"--state={k}={v}" for k, v in LONG_GAIT_0175.items()]
    argv = ["sweep", "--model", "simplest-walker", "--over", "gamma=0.0175:0.0176:2", *state,
            "--transient", "0", "--keep", "8", "--max-steps", "8"]  # fmt: skip
    code, out, err = run(capsys, [*argv, "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert data["max_steps"] == 8
    assert "within 1e-08 x max(1, |x|)" in data["provenance"]["tolerances"]["attractor"]
    for point in data["points"]:
        attractor = point["attractor"]
        assert attractor["ended"] == "completed" and attractor["steps_walked"] == 8
        assert attractor["settled"] is False and attractor["period"] is None
        assert len(attractor["states"]) == 8
    code, out, err = run(capsys, argv)
    assert code == 0 and out.count("map: not settled after 8 steps") == 2, out


def test_a_long_transient_raises_the_default_cap(capsys):
    """--transient 2100 beyond the default cap of 2000 steps: the cap becomes transient +
    keep, and the walk settles on the period-2 orbit (below the flip at 0.0176694)."""
    state = [f"--state={k}={v}" for k, v in LONG_GAIT_0175.items()]
    argv = ["sweep", "--model", "simplest-walker", "--over", "gamma=0.0175:0.0176:2", *state,
            "--transient", "2100", "--keep", "8", "--json"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    data = json.loads(out)
    assert data["max_steps"] == 2108
    for point in data["points"]:
        assert point["attractor"]["steps_walked"] == 2108
        assert point["attractor"]["period"] == expected_period(point["gamma"]) == 2


def test_the_start_chooses_the_gait(capsys):
    """At gamma = 0.0174 both period-one gaits are unstable; the search's first (the short
    gait) lifts off within a few steps. Started from Garcia's long gait (--state, or --gait-number
    as vsw analyze numbers it) the sweep walks and settles on period 2 (below 0.0176694)."""
    over = ["--model", "simplest-walker", "--over", "gamma=0.0174:0.0176:3", "--keep", "8"]
    default = json.loads(run(capsys, ["sweep", *over, "--json"])[1])
    assert all(p["attractor"]["ended"] == "lift-off" for p in default["points"])
    analyzed = json.loads(run(capsys, ["analyze", *over[:2], "--param", "gamma=0.0174",
                                       "--json"])[1])  # fmt: skip
    gaits = analyzed["fixed_points"]
    long_gait = max(range(len(gaits)), key=lambda k: gaits[k]["period"])
    state = [f"--state={k}={v!r}" for k, v in gaits[long_gait]["state"].items()]
    by_state = json.loads(run(capsys, ["sweep", *over, *state, "--json"])[1])
    by_index = json.loads(run(capsys, ["sweep", *over, "--gait-number", str(long_gait + 1),
                                       "--json"])[1])  # fmt: skip
    assert by_state["points"][0]["from"] == "--state"
    assert by_index["points"][0]["from"] == f"--gait-number {long_gait + 1}"
    for data in (by_state, by_index):
        for point in data["points"]:
            assert point["attractor"]["ended"] == "completed"
            assert point["attractor"]["period"] == expected_period(point["gamma"]) == 2
    first = by_state["points"][0]["state"]
    assert first == pytest.approx(gaits[long_gait]["state"], abs=1e-9)


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--gait-number", "0"], ["--gait-number 0", "from 1"]),
        (["--gait-number", "9"], ["--gait-number 9", "1 to 2"]),
        (["--gait-number", "1", "--state", "theta=0"], ["--state", "--gait-number"]),
        (["--state", "theta=0"], ["--state", "phi"]),
        (["--state", "theta=-0.2", "--state", "phi=-0.4", "--state", "theta_dot=5",
          "--state", "phi_dot=0"], ["--state", "no"]),
        (["--keep", "8", "--max-steps", "20"], ["--max-steps 20", "108"]),
        (["--max-steps", "50"], ["--max-steps", "--keep N"]),
    ],
)  # fmt: skip
def test_bad_start_and_cap_are_one_line(capsys, extra, words):
    argv = ["sweep", "--model", "simplest-walker", "--over", "gamma=0.0174:0.0176:2", *extra]
    code, out, err = run(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    for word in words:
        assert word in err, err


def test_help_documents_the_start_and_the_cap(capsys):
    assert main(["sweep", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for words in ("--state NAME=VALUE", "--gait-number K", "--max-steps M", "not settled after M",
                  "numbered as 'vsw analyze' lists them"):  # fmt: skip
        assert words in text, words
