"""``vsw explore``: the page in a real browser (headless Chromium through Playwright).

Each slider is moved by keyboard; the page's q^f, eigenvalue and condition margins are
compared with ``vsw analyze`` at the sliders' values; the console must stay free of
errors; a screenshot is saved to reports/explore.png for a person to look at. Chromium is
Debian's (``.ci/run`` installs it with apt-get where it can); without a browser the test
is skipped with the reason.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tests.conftest import chromium_path, headless_page
from vsw.cli import main

ROOT = Path(__file__).resolve().parent.parent


def _analyze(capsys, beta, theta_II_deg, phi0_deg) -> dict:
    argv = ["analyze", "--beta", repr(beta), "--theta-ii", repr(theta_II_deg), "--phi0",
            repr(phi0_deg), "--json"]  # fmt: skip
    assert main(argv) == 0
    out, _ = capsys.readouterr()
    return json.loads(out)


def test_page_is_self_contained(tmp_path, capsys):
    out = tmp_path / "explore.html"
    assert main(["explore", "--out", str(out)]) == 0
    text = out.read_text()
    assert "function fixed_point_conditions(" in text  # the generated JavaScript, inlined
    for remote in ("http://", "https://", "src=", "<link"):
        assert remote not in text, remote
    assert text == (tmp_path / "explore.html").read_text()
    second = tmp_path / "again.html"
    assert main(["explore", "--out", str(second)]) == 0
    assert second.read_bytes() == out.read_bytes()


@pytest.mark.parametrize(
    "argv, words",
    [
        (["explore", "--out", "x.txt"], [".html"]),
        (["explore", "--out", "TMP/missing/dir/x.html"], ["does not exist"]),
        (["explore", "--out", "x.html", "--beta", "1.5"], ["--beta", "(0, 1)"]),
        (["explore", "--out", "x.html", "--beta", "0.1"], ["--beta", "slider range"]),
        (["explore", "--out", "x.html", "--phi0", "nan"], ["--phi0"]),
    ],
)
def test_bad_explore_input_is_one_line(capsys, tmp_path, monkeypatch, argv, words):
    """TMP: the test's own temporary directory, where missing/ is sure to be missing."""
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("TMP", str(tmp_path)) for a in argv]
    assert not (tmp_path / "missing").exists()
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1
    for word in words:
        assert word in err, err


SHOWS_THE_SLIDERS = """() => {
  const u = window.vswLastUpdate.state, v = (id) => Number(document.getElementById(id).value);
  return u.beta === v("beta") && u.theta_II === v("theta_II") * (Math.PI / 180)
    && u.phi0 === v("phi0") * (Math.PI / 180) && u.leg === v("leg");
}"""


def test_page_in_headless_chromium(tmp_path, capsys):
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    browser_path = chromium_path()
    if browser_path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    page_file = tmp_path / "explore.html"
    assert main(["explore", "--out", str(page_file)]) == 0
    capsys.readouterr()
    errors: list[str] = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 900})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_file.as_uri())
            page.wait_for_function("window.vswLastUpdate !== undefined")
            checked, timings = 0, []
            for slider, key in (("beta", "ArrowLeft"), ("theta_II", "ArrowRight"),
                                ("phi0", "ArrowLeft"), ("leg", "ArrowRight")):  # fmt: skip
                before = page.evaluate("JSON.stringify(window.vswLastUpdate.state)")
                page.focus(f"#{slider}")
                for _ in range(5):
                    page.keyboard.press(key)
                page.wait_for_function(
                    f"JSON.stringify(window.vswLastUpdate.state) !== {json.dumps(before)}"
                )
                # ... and until the last key press is shown (updates wait for a frame).
                page.wait_for_function(SHOWS_THE_SLIDERS)
                shown = page.evaluate("window.vswLastUpdate")
                values = {k: float(page.input_value(f"#{k}")) for k in ("beta", "theta_II",
                                                                         "phi0")}  # fmt: skip
                assert shown["state"]["beta"] == values["beta"]
                label = page.text_content(f"#{slider}-value")
                assert page.input_value(f"#{slider}") in label  # the value, with its unit
                ref = _analyze(capsys, values["beta"], values["theta_II"], values["phi0"])
                assert shown["q_f"] == pytest.approx(ref["q_fixed"], rel=1e-12)
                assert shown["eigenvalue"] == pytest.approx(ref["eigenvalue"], rel=1e-12)
                assert shown["walks"] == ref["walks"]
                for c in ref["conditions"]:
                    assert shown["conditions"][c["name"]] == pytest.approx(
                        c["value"], rel=1e-12, abs=1e-15), c["name"]  # fmt: skip
                # What the page displays is the same number, to its six digits.
                displayed = float(page.text_content("#q_f"))
                assert math.isclose(displayed, ref["q_fixed"], rel_tol=5e-6)
                timings.append(shown["ms"])
                checked += 1
            assert checked == 4
            rows = page.eval_on_selector_all("#conditions tr", "rows => rows.length")
            assert rows == len(ref["conditions"])
            reports = ROOT / "reports"
            reports.mkdir(exist_ok=True)
            page.screenshot(path=str(reports / "explore.png"), full_page=True)
        finally:
            browser.close()
    assert errors == [], errors
    # One update's time in this headless browser (the first includes the map at a new beta).
    print(f"explorer updates: {', '.join(f'{t:.1f} ms' for t in timings)}")


@pytest.mark.parametrize("width", [360, 700])
def test_page_fits_narrow_screens_and_says_its_units(tmp_path, capsys, width):
    """No horizontal overflow from 360 px up; the margins carry units (angles in
    degrees, as the sliders); the conditions read in words; the basin says when it is
    empty (beta = 0.3, theta_II = -40 deg: the apex needs more q than contact allows)."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    browser_path = chromium_path()
    if browser_path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    page_file = tmp_path / "explore.html"
    argv = ["explore", "--beta", "0.3", "--theta-ii", "-40", "--out", str(page_file)]
    assert main(argv) == 0
    capsys.readouterr()
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": width, "height": 800})
            page.goto(page_file.as_uri())
            page.wait_for_function("window.vswLastUpdate !== undefined")
            overflow = page.evaluate(
                "document.documentElement.scrollWidth - document.documentElement.clientWidth"
            )
            assert overflow <= 0, f"{overflow} px of horizontal overflow at {width} px"
            basin = page.text_content("#basin")
            assert basin.startswith("empty:"), basin
            margins = page.eval_on_selector_all(
                "#conditions tr", "rows => rows.map(r => [r.dataset.condition, "
                "r.children[1].textContent, r.children[3].textContent])",
            )  # fmt: skip
            by_name = {name: (label, value) for name, label, value in margins}
            assert by_name["phi0_below_right_angle"][1].endswith("°")
            assert by_name["apex"][1].endswith("g/r_e")
            assert by_name["stance_contact"][1].endswith("m g")
            assert "theta_I_negative" not in " ".join(label for label, _ in by_name.values())
            assert page.text_content("#map-max") != "" or page.evaluate(
                "!window.vswLastUpdate.walks")  # fmt: skip
        finally:
            browser.close()


ENGINE = ("rimless-wheel", "tle", "simplest-walker", "compass-gait", "vsw-biped")


@pytest.mark.slow  # a browser and a search per model
@pytest.mark.parametrize("model", ENGINE)
def test_every_model_explorer_finds_the_gait_vsw_finds(tmp_path, capsys, model):
    """`vsw explore --model NAME`: the page integrates the walk with the
    generated JavaScript and finds the period-one gait by Newton from the one vsw found;
    its period and step length equal `vsw analyze`'s to 1e-9 relative, the largest
    |eigenvalue| (central differences at two steps, extrapolated, in the page) to 1e-8; a
    slider moved by keyboard gives a new gait; no console error; no horizontal overflow at
    360 px."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    browser_path = chromium_path()
    if browser_path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    page_file = tmp_path / "explore.html"
    assert main(["explore", "--model", model, "--out", str(page_file)]) == 0
    assert main(["analyze", "--model", model, "--json"]) == 0
    out, _ = capsys.readouterr()
    gaits = json.loads(out[out.index("{") :])["fixed_points"]
    errors: list[str] = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": 360, "height": 800})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_file.as_uri())
            page.wait_for_function("window.vswLastUpdate !== undefined", timeout=60_000)
            shown = page.evaluate("window.vswLastUpdate")
            assert shown["walks"], "the page lost the gait it started from"
            ref = min(gaits, key=lambda g: abs(g["period"] - shown["period"]))
            assert shown["period"] == pytest.approx(ref["period"], rel=1e-9)
            assert shown["step_length"] == pytest.approx(ref["step_length"], rel=1e-9)
            assert shown["max_abs_eigenvalue"] == pytest.approx(ref["max_abs_eigenvalue"],
                                                                rel=1e-8)  # fmt: skip
            overflow = page.evaluate(
                "document.documentElement.scrollWidth - document.documentElement.clientWidth"
            )
            assert overflow <= 0, f"{overflow} px of horizontal overflow at 360 px"
            page.evaluate("window.firstParams = JSON.stringify(window.vswLastUpdate.params)")
            slider = page.eval_on_selector("input[type=range]", "el => el.id")
            page.focus(f"#{slider}")
            for _ in range(3):
                page.keyboard.press("ArrowRight")
            page.wait_for_function(
                "JSON.stringify(window.vswLastUpdate.params) !== window.firstParams",
                timeout=60_000,
            )
            moved = page.evaluate("window.vswLastUpdate")
            assert moved["params"] != shown["params"]
        finally:
            browser.close()
    assert errors == [], errors


PICTURES = """() => {
  const u = window.vswLastUpdate, out = [];
  for (let i = 0; i <= 90; ++i) out.push(window.vswPicture(3 * u.period * i / 90));
  return out;
}"""


@pytest.mark.slow
@pytest.mark.parametrize("model", ["kneed-walker", "torso-walker"])
def test_the_explorer_draws_the_models_own_skeleton(tmp_path, capsys, model):
    """Over three steps of the page's gait, the page's own drawing function
    (``vswPicture``, what its canvas paints) draws every segment of the phase's skeleton
    inside the canvas, at the points numpy's generated ``<phase>_skeleton`` gives at the
    drawn state (the pixel transform undone), the kneed walker's knee bent in its
    knee-free phase, the torso above the hip; the view follows the hip while the ground
    scrolls by, a step length a step."""
    import numpy as np

    from vsw.models import load

    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    browser_path = chromium_path()
    if browser_path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    page_file = tmp_path / "explore.html"
    assert main(["explore", "--model", model, "--out", str(page_file)]) == 0
    capsys.readouterr()
    errors: list[str] = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 800})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_file.as_uri())
            page.wait_for_function("window.vswLastUpdate !== undefined", timeout=120_000)
            shown = page.evaluate("window.vswLastUpdate")
            assert shown["walks"], "the page lost the gait it started from"
            pictures = page.evaluate(PICTURES)
            canvas = page.eval_on_selector("#walk", "c => [c.width, c.height]")
        finally:
            browser.close()
    assert errors == [], errors
    walker = load(model)
    params = shown["params"]
    phases = {ph["name"]: ph["skeleton"] for ph in walker.phases}
    names = (*walker.coordinates, *walker.rates)
    bent = 0
    for pic in pictures:
        assert [pic["width"], pic["height"]] == canvas
        drawing = phases[pic["phase"]]
        assert [tuple(s) for s in pic["segments"]] == [tuple(s) for s in drawing["segments"]]
        assert len(pic["lines"]) >= len(drawing["segments"])
        for a, b, _ in pic["lines"]:
            for x, y in (a, b):
                assert 0 <= x <= canvas[0] and 0 <= y <= canvas[1], (pic["t"], x, y)
        # the pixels back in the chart: pixel = origin + scale (X, -Y), (X, Y) turned
        c, s = math.cos(pic["slope"]), math.sin(pic["slope"])
        u = (np.array(pic["points"]) - pic["origin"]) / pic["scale"]
        chart = np.column_stack([c * u[:, 0] + s * u[:, 1], s * u[:, 0] - c * u[:, 1]])
        skeleton = np.asarray(
            getattr(walker.module, f"{pic['phase']}_skeleton")(*params, *pic["state"]), float
        ).reshape(-1, 2)
        foot = chart[0] - skeleton[0]  # the stance foot, the skeleton's first point
        assert drawing["points"][0] == "stance_foot" and abs(foot[1]) < 1e-9
        assert foot[0] == pytest.approx(pic["foot"], abs=1e-9)
        assert np.allclose(chart - foot, skeleton, rtol=0, atol=1e-9), pic["t"]
        for (a, b, _), (p0, p1) in zip(pic["lines"], drawing["segments"]):
            assert np.allclose([a, b], np.array(pic["points"])[
                [drawing["points"].index(p0), drawing["points"].index(p1)]])  # fmt: skip
        state = dict(zip(names, pic["state"]))
        bent += pic["phase"] == "knee_free" and state["kappa"] > 0.3
        if "torso" in drawing["points"]:
            torso = np.array(pic["points"])[drawing["points"].index("torso")]
            assert torso[1] < pic["hip"][1]  # above the hip on the screen
    if model == "kneed-walker":
        assert bent >= 3
    hips = np.array([pic["hip"] for pic in pictures])
    assert np.ptp(hips[:, 0]) < 1e-6  # the view follows the hip...
    first, last = pictures[0], pictures[-1]
    steps = last["step"] - first["step"]
    assert steps >= 2
    assert last["foot"] - first["foot"] == pytest.approx(steps * shown["step_length"], rel=1e-9)

    def hip_along(pic):  # the hip's turned x in the first step's chart, from numpy
        xy = getattr(walker.module, f"{pic['phase']}_skeleton")(*params, *pic["state"])
        k = phases[pic["phase"]]["points"].index("hip")
        x, y = pic["foot"] + float(xy[2 * k]), float(xy[2 * k + 1])
        return math.cos(pic["slope"]) * x + math.sin(pic["slope"]) * y

    # ... and the ground moves back under it as far as the hip walked
    moved = first["origin"][0] - last["origin"][0]
    assert moved == pytest.approx(first["scale"] * (hip_along(last) - hip_along(first)), abs=1e-6)


# Every word of every table cell's text on one line: a word broken inside wraps onto a
# second line box, so the range over it has more than one client rectangle.
BROKEN_WORDS = """() => {
  const broken = [];
  for (const cell of document.querySelectorAll("td, th")) {
    const walker = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    for (let node = walker.nextNode(); node; node = walker.nextNode()) {
      for (const m of node.data.matchAll(/\\S+/g)) {
        const range = document.createRange();
        range.setStart(node, m.index);
        range.setEnd(node, m.index + m[0].length);
        const tops = new Set([...range.getClientRects()].map((r) => Math.round(r.top)));
        if (tops.size > 1) broken.push(m[0]);
      }
    }
  }
  return broken;
}"""


@pytest.mark.parametrize("width", [360, 1280])
def test_table_cells_never_break_inside_a_word(tmp_path, capsys, width):
    """At a phone's and a desktop's width no table cell breaks a word across lines (the
    conditions table scrolls in its own box instead), the page does not scroll sideways,
    and the console stays free of errors."""
    page_file = tmp_path / "explore.html"
    assert main(["explore", "--out", str(page_file)]) == 0
    capsys.readouterr()
    with headless_page(page_file.as_uri(), width) as (page, errors):
        page.wait_for_function("window.vswLastUpdate !== undefined")
        assert page.eval_on_selector_all("#conditions tr", "rows => rows.length") > 0
        broken = page.evaluate(BROKEN_WORDS)
        assert broken == [], f"words broken across lines at {width} px: {broken}"
        overflow = page.evaluate(
            "document.documentElement.scrollWidth - document.documentElement.clientWidth"
        )
        assert overflow <= 0, f"{overflow} px of horizontal overflow at {width} px"
    assert errors == [], errors


def _documented_flips() -> tuple[float, float]:
    """The compass gait's first period doubling and where its walks fail (degrees), as
    docs/models/passive_walkers.md reports them."""
    import re

    text = (ROOT / "docs" / "models" / "passive_walkers.md").read_text()
    flip = re.search(r"first period doubling at ([\d.]+)°", text)
    fail = re.search(r"walks fail by lift-off from ([\d.]+)°", text)
    assert flip and fail, "the compass gait's cascade is no longer in the docs"
    return float(flip.group(1)), float(fail.group(1))


def test_the_slope_slider_reaches_the_compass_gaits_period_doublings():
    """The hybrid explorer's slope slider spans the parameter table's interval, so it
    reaches past the compass gait's first period doubling and on to where its walks fail;
    every slider's grid passes through its start value, strictly inside the interval."""
    from vsw.models import load
    from vsw.plots.explore_page import FINE, WIDE, spec

    model = load("compass-gait")
    params = model.parameters()
    sliders = {s["name"]: s for s in spec(model, params, [0.0] * 4)["parameters"]}
    flip, fail = _documented_flips()
    gamma = sliders["gamma"]
    assert gamma["min"] < 1.0 and gamma["max"] > fail > flip
    assert gamma["max"] >= 90.0 - 2 * gamma["step"]  # the table's (0, pi/2), in degrees
    assert gamma["step"] <= 1e-3 * gamma["value"]  # as fine near the start as across it
    for p, value in zip(model.parameter_table, params):
        s = sliders[p.name]
        shown = math.degrees(value) if p.unit == "rad" else value
        k = (shown - s["min"]) / s["step"]
        assert abs(k - round(k)) < 1e-6, p.name  # the start value is on the grid
        assert s["step"] <= FINE * abs(shown) * 1.005, p.name
        low, high = (math.degrees(v) for v in (p.lower, p.upper)) if p.unit == "rad" else (
            p.lower, p.upper)  # fmt: skip
        assert low < s["min"] <= shown <= s["max"] < high, p.name
        if not math.isfinite(p.upper):  # a scale: a tenth to ten times its value
            assert s["min"] <= shown / WIDE + s["step"] and s["max"] >= shown * WIDE - s["step"]
