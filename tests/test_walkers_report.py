"""``python -m paper_check --model NAME`` (paper_check.walkers): the walkers' reports.

The numbers themselves are checked in tests/test_passive_walkers.py and
tests/test_vsw_biped.py; here: the command writes its report and figures, the rows that
must agree do, the rows that differ say why, and the output is the same run after run.
"""

from __future__ import annotations

import re

import pytest

from paper_check.__main__ import main as paper_check_main
from paper_check.walkers import main


def _rows(text: str) -> list[list[str]]:
    return [
        [cell.strip() for cell in line.strip("|").split("|")]
        for line in text.splitlines()
        if line.startswith("| ")
        and "---" not in line
        and not line.startswith(("| quantity", "| beta", "| gamma", "| gait"))
    ]


@pytest.fixture(scope="module")
def simplest_walker_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("walkers")
    # --quick: the coarse diagram; every compared number is the full report's.
    assert main(["--model", "simplest-walker", "--quick", "--out", str(out)]) == 0
    return out


@pytest.mark.slow
def test_simplest_walker_report_verdicts(simplest_walker_report):
    text = (simplest_walker_report / "simplest-walker.md").read_text()
    verdicts = {}
    for row in _rows(text):
        if len(row) == 8:
            verdicts[(row[0], row[1])] = (row[6], row[7])
    # Every gait coordinate and step period agrees with both codes; the loss of stability
    # with the paper; Table 1 but the long gait's Theta1; Garcia's eigenvalues do not.
    agree = [k for k, (v, _) in verdicts.items() if v == "agrees"]
    differ = sorted(k for k, (v, _) in verdicts.items() if v == "differs")
    assert len(agree) == 23, agree
    assert differ == sorted([
        ("long gait Theta1", "G98T1"),
        ("long gait eigenvalue, imaginary part", "G98code"),
        ("long gait eigenvalue, real part", "G98code"),
        ("short gait eigenvalue 1", "G98code"),
        ("short gait eigenvalue 2", "G98code"),
    ])  # fmt: skip
    # A row that differs says what we found about why.
    for key in differ:
        why = verdicts[key][1]
        assert ("central differences" in why) if "eigenvalue" in key[0] else (
            "G98code's theta" in why), (key, why)  # fmt: skip
    # The diagram: stable, then period-2 past the loss of stability.
    assert re.search(r"\| 0.0155 \| [0-9.]+ \| unstable \| [0-9.]+ \| period-2 \|", text)
    for name in ("simplest-walker_bifurcation.png", "simplest-walker_bifurcation.svg",
                 "simplest-walker_basin.png", "simplest-walker_brute-force.png"):  # fmt: skip
        assert (simplest_walker_report / name).stat().st_size > 10_000
    # The basin (batch simulator): converged and fell cells, a thin band (about 1 %).
    share = re.search(r"converged: \d+ cells \(([0-9.]+) %\)", text)
    assert share and 0.3 < float(share.group(1)) < 5, share
    assert "brute-force" in text and "period-2 from" in text


@pytest.mark.slow
def test_kneed_walker_report_verdicts(tmp_path):
    """The independent re-implementation's gait agrees in every row; Hsu Chen's period
    agrees within its figure's 2 % and her angles and rate, as quoted, differ (the report
    says what is known about why); the report is the same run after run."""
    texts = []
    for run in ("a", "b"):
        out = tmp_path / run
        assert main(["--model", "kneed-walker", "--quick", "--out", str(out)]) == 0
        texts.append((out / "kneed-walker.md").read_text())
    assert texts[0] == texts[1]
    verdicts = {(row[0], row[1]): row[6] for row in _rows(texts[0])
                if len(row) == 8 and row[1] in ("HC07", "NC26")}  # fmt: skip
    assert len(verdicts) == 10
    assert all(v == "agrees" for (_, source), v in verdicts.items() if source == "NC26")
    differ = sorted(q for (q, source), v in verdicts.items() if v == "differs")
    assert differ == sorted([
        "stance angle from the vertical just after heelstrike, q1 (rad)",
        "stance rate just after heelstrike, -q1_dot (rad/s)",
        "stance angle from the slope normal at heelstrike (rad)",
    ])  # fmt: skip
    assert "not known to us" in texts[0]


def test_vsw_biped_report_is_deterministic(tmp_path):
    runs = []
    for k in range(2):
        out = tmp_path / str(k)
        assert main(["--model", "vsw-biped", "--quick", "--out", str(out)]) == 0
        runs.append({p.name: p.read_bytes() for p in sorted(out.iterdir())})
    assert runs[0] == runs[1]
    assert set(runs[0]) == {"vsw-biped.md", "vsw-biped_mu.png", "vsw-biped_mu.svg"}
    rows = _rows(runs[0]["vsw-biped.md"].decode())
    # beta = 0.8, theta_II = 0.1: the gait continued to mu = 0.3, lost at mu = 0.5, and
    # the row says why (the heelstrike angle past theta_II: a negative phase duration).
    assert [r[2] for r in rows] == ["0.0001", "0.001", "0.01", "0.03", "0.1", "0.3", "0.5"]
    assert "no gait by continuation" in rows[-1][3]
    assert "phase duration is not positive" in rows[-1][3]


def test_bad_output_directory_is_one_line(capsys):
    assert main(["--model", "vsw-biped", "--out", ""]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    # python -m paper_check --model NAME is this command (its check, its message).
    assert paper_check_main(["--model", "vsw-biped", "--out", "/proc/no"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("paper_check.walkers: error:") and err.count("\n") == 1


@pytest.mark.slow
def test_point_mass_biped_report_agrees_with_its_derivation_and_is_deterministic(tmp_path):
    """Srinivasan & Ruina's inverted-pendulum walking: every compared row agrees (the
    optimiser's least work and push-off against the cost derived in paper_check/powered.py),
    the faster gait is not called optimal, the ILE's price is a ratio above 1 (its least
    work unchanged where the legs' switch point is chosen too), and two runs write the same
    bytes."""
    runs = []
    for k in range(2):
        out = tmp_path / str(k)
        assert main(["--model", "point-mass-biped", "--quick", "--out", str(out)]) == 0
        runs.append((out / "point-mass-biped.md").read_bytes())
    assert runs[0] == runs[1]
    text = runs[0].decode()
    rows = _rows(text)
    compared = [r for r in rows if len(r) == 8]
    assert len(compared) == 4 and all(r[6] == "agrees" for r in compared), compared
    (faster,) = [r for r in rows if r[0] == "0.9" and len(r) == 7]
    assert faster[1] == "not-converged"
    (ile,) = [r for r in rows if r[0] == "0.8" and len(r) == 12]
    assert ile[-1] == "optimal" and float(ile[-2]) > 1
    assert ile[8] == ile[10]  # optimal: the least work found is inverted-pendulum walking's
    # The price over speeds and step lengths (quick: V 0.3, d 0.5): VSW's cheapest gait is
    # where its gaits end (the extension at heel-strike), still dearer than the optimum.
    (grid,) = [r for r in rows if r[:2] == ["0.3", "0.5"] and len(r) == 13]
    assert "where its gaits end" in grid[2] and grid[10] == "optimal"
    assert float(grid[7]) > 1 and grid[5] == grid[8]
    # With the legs' switch point chosen too, from either side of the midpoint, the optimum
    # switches midway: the least work is the midpoint model's.
    sigma, least = (float(v) for v in grid[11].split(", "))
    assert abs(sigma - 0.5) < 1e-6 and f"{least:.6f}" == grid[8] and grid[12] == "optimal"


def test_kuo_walker_report_agrees_with_its_derivation_and_is_deterministic(tmp_path):
    """Kuo's ratio (one case, quick): the push-off's and the stance torque's least work
    against their derivation in paper_check/kuo.py, their ratio 4 cos^4(alpha), the
    continuous torque not called optimal, and two runs write the same bytes."""
    runs = []
    for k in range(2):
        out = tmp_path / str(k)
        assert main(["--model", "kuo-walker", "--quick", "--out", str(out)]) == 0
        runs.append((out / "kuo-walker.md").read_bytes())
    assert runs[0] == runs[1]
    rows = _rows(runs[0].decode())
    compared = [r for r in rows if len(r) == 8]
    assert len(compared) == 3 and all(r[6] == "agrees" for r in compared), compared
    (smooth,) = [r for r in rows if len(r) == 6 and r[0] == "0.6"]
    assert smooth[3] != "optimal" and float(smooth[2]) > float(smooth[5])


@pytest.mark.slow
def test_vsw_price_report_bounds_vsw_by_a_verified_gait_and_is_deterministic(tmp_path):
    """VSW's price on its own biped (quick: the defaults' gait): the body's least-work gait
    found is verified (a periodic motion of the walker, its step's gap within 1e-7), at
    the VSW gait's speed and step within 1e-3, its landing pushed within the friction cone
    of 1 and its stance within it (at the knots; within 1 % between them), and it costs
    less than the VSW gait (a ratio above 1); two runs write the same bytes."""
    runs = []
    for k in range(2):
        out = tmp_path / str(k)
        assert main(["--model", "free-vsw-biped", "--quick", "--out", str(out)]) == 0
        runs.append((out / "free-vsw-biped.md").read_bytes())
    assert runs[0] == runs[1]
    (row,) = [r for r in _rows(runs[0].decode()) if r[0] == "defaults"]
    speed, step, vsw_work = (float(v) for v in row[1:4])
    verified = row[6]
    work, rest = verified.split(" (")
    v, s, gap = (float(x) for x in rest.rstrip(")").replace(";", ",").split(","))
    assert abs(v - speed) < 1e-3 * speed and abs(s - step) < 1e-3 * step and gap <= 1e-7
    normal, tangential = (float(x) for x in row[7].split(","))
    assert normal >= 0 and abs(tangential) <= normal * (1 + 1e-6)
    assert float(row[8]) <= 1.01  # the cone holds at the knots, between them to the mesh's error
    assert float(row[9]) == pytest.approx(vsw_work / float(work), rel=1e-2)
    assert float(row[9]) > 1
    weight = 1 + 2 * 0.1  # the hip and two legs of mu = 0.1, in m_H g
    assert float(row[10]) == pytest.approx(vsw_work / (weight * step), rel=1e-5)
    assert float(row[11]) == pytest.approx(float(work) / (weight * s), rel=1e-5)


@pytest.mark.slow
def test_a_grid_cell_of_the_vsw_price_is_a_designed_vsw_gait_against_a_verified_body_gait():
    """One cell of the VSW-price grid (V 0.25, S 0.65): the VSW biped designed there (beta
    and b/l, from a start near it) walks at that speed and step (one simulated step from
    its state returns to it, its length the target's), and the row beside it prices it
    against a verified gait of the same body at the same speed and step (within 1e-3), a
    ratio above 1 that is VSW's work over the verified work."""
    import numpy as np

    from paper_check.vsw_price import GRID_FIXED, _grid_row
    from vsw.models import load
    from vsw.synthesis.design import DesignRequest, design

    biped = load("vsw_biped")
    designed = design(biped, DesignRequest(targets={"speed": 0.25, "step_length": 0.65},
                                           fixed=GRID_FIXED,
                                           start={"beta": 0.95, "b_over_l": 0.5}))  # fmt: skip
    assert designed.status == "optimal", designed.message
    params = biped.parameters(designed.parameters)
    state = np.array(list(designed.orbit.state.values()))
    step = biped.step(params, state)  # SciPy's DOP853, not the design's CVODES
    assert step.ended == "completed"
    assert np.max(np.abs(step.state - state)) <= 1e-8
    assert step.step_length == pytest.approx(0.65, abs=1e-8)
    assert step.step_length / sum(step.durations) == pytest.approx(0.25, abs=1e-8)
    (row,) = _rows(_grid_row(0.25, 0.65, designed))
    assert [float(x) for x in row[2].split(",")] == pytest.approx(
        [designed.parameters["beta"], designed.parameters["b_over_l"]], abs=1e-4
    )
    vsw_work, verified = float(row[5]), row[7]
    work, rest = verified.split(" (")
    v, s, gap = (float(x) for x in rest.rstrip(")").replace(";", ",").split(","))
    assert abs(v - 0.25) < 1e-3 * 0.25 and abs(s - 0.65) < 1e-3 * 0.65 and gap <= 1e-7
    assert float(row[10]) == pytest.approx(vsw_work / float(work), rel=1e-2)
    assert float(row[10]) > 1
