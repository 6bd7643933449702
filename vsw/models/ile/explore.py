"""``vsw explore``: one self-contained HTML page to explore the ILE in a browser.

The page (``vsw/models/ile/templates/explore.html``) inlines ``generated/ile/js/ile.js``, the
JavaScript ``python -m derive`` prints from the derivation (:mod:`derive.js_codegen`):
q^f, the eigenvalue, every existence condition's margin, the step length and period
(Carlson form), the basin interval, the gait's dynamics and resets. No number on the page
is typed in, nothing is fetched, and it opens from disk.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import generated
import generated.ile as ile
from vsw.plots.explore_page import check_html_path, write_html
from vsw.runtime.errors import VswInputError

TEMPLATE = Path(__file__).resolve().parent / "templates" / "explore.html"
MODEL_JS = Path(generated.__file__).resolve().parent / "ile" / "js" / "ile.js"

# The sliders' ranges (the template's min/max): beta, theta_II [deg], phi0 [deg], r_e [m].
RANGES = {"beta": (0.30, 0.99), "theta_II": (-40.0, 40.0), "phi0": (5.0, 89.0), "leg": (0.1, 2.0)}


def page(beta: float = 0.8, theta_II_deg: float = 0.0, phi0_deg: float = 45.0,
         leg: float = 0.25) -> str:  # fmt: skip
    """The page's HTML with the sliders at the given start values."""
    values = {"beta": beta, "theta_II": theta_II_deg, "phi0": phi0_deg, "leg": leg}
    for name, value in values.items():
        low, high = RANGES[name]
        if not (math.isfinite(value) and low <= value <= high):
            shown = {"theta_II": "--theta-ii", "leg": "--leg-length"}.get(name, f"--{name}")
            raise VswInputError(f"{shown} = {value:g} is outside the explorer's slider range "
                                f"[{low:g}, {high:g}]")  # fmt: skip
    js = MODEL_JS.read_text()
    if "</script" in js:  # cannot happen with generated code; would end the inline script
        raise VswInputError("generated/ile/js/ile.js contains '</script'")
    text = TEMPLATE.read_text()
    replacements = {
        "@@generated_from@@": "generated/ile/js/ile.js",
        "@@beta@@": f"{beta:g}",
        "@@theta_II@@": f"{theta_II_deg:g}",
        "@@phi0@@": f"{phi0_deg:g}",
        "@@leg@@": f"{leg:g}",
        "@@condition_units@@": json.dumps(dict(ile.CONDITION_UNITS), sort_keys=True),
        "@@model_js@@": js,
    }
    for key, value in replacements.items():
        text = text.replace(key, value)
    return text


def write_page(path: str, **values: float) -> Path:
    """Write the page of :func:`page` with the sliders at ``values``."""
    check_html_path(path)
    return write_html(path, page(**values))
