"""Every model's explorer page in headless Chromium, at a phone's and a desktop's width:
no console error, no sideways scrolling, and over a whole step of the page's gait every
body of the phase drawn and every segment and body inside the canvas.

The ILE's page (its closed forms, its own template) has its own tests in
tests/test_explore.py; the skeleton's points against numpy's are checked there for the
kneed and torso walkers and in tests/test_drawing.py for the animation of every model.
"""

from __future__ import annotations

import pytest

from tests.conftest import headless_page, passive_keys
from vsw.cli import main
from vsw.models import load

pytestmark = pytest.mark.slow  # a browser, a page and its gait per model

WIDTHS = (360, 1280)

# vswPicture(t) is what the canvas paints at time t of the walk (explore_hybrid.html).
ONE_STEP = """() => {
  const u = window.vswLastUpdate, out = [];
  for (let i = 0; i <= 40; ++i) out.push(window.vswPicture(u.period * i / 40));
  return out;
}"""

OVERFLOW = "document.documentElement.scrollWidth - document.documentElement.clientWidth"


def _outside(pic: dict) -> list[tuple[float, float]]:
    width, height = pic["width"], pic["height"]
    points = [p for a, b, _ in pic["lines"] for p in (a, b)]
    points += [(x, y) for x, y, _, _ in pic["bodies"]]
    return [(x, y) for x, y in points if not (0 <= x <= width and 0 <= y <= height)]


# A powered-only model's page replays a gait file (tests/test_gait_replay.py).
@pytest.mark.parametrize("key", [k for k in passive_keys() if k != "ile"])
def test_every_model_page_draws_every_body_inside_its_canvas(tmp_path, capsys, key):
    walker = load(key)
    bodies = {ph["name"]: len(ph["skeleton"]["bodies"]) for ph in walker.phases}
    page_file = tmp_path / "explore.html"
    assert main(["explore", "--model", walker.name, "--out", str(page_file)]) == 0
    capsys.readouterr()
    for width in WIDTHS:
        with headless_page(page_file.as_uri(), width) as (page, errors):
            page.wait_for_function("window.vswLastUpdate !== undefined", timeout=120_000)
            assert page.evaluate(OVERFLOW) <= 0, f"sideways scrolling at {width} px"
            assert page.evaluate("window.vswLastUpdate.walks"), "the page lost its gait"
            for pic in page.evaluate(ONE_STEP):
                assert len(pic["bodies"]) == bodies[pic["phase"]], (width, pic["t"])
                assert _outside(pic) == [], (width, pic["t"], pic["phase"])
        assert errors == [], (width, errors)
