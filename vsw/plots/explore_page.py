"""``vsw explore --model NAME`` for the engine's models: one self-contained HTML page.

The page (``vsw/plots/templates/explore_hybrid.html``) inlines ``generated/<model>/js/<model>.js``,
the JavaScript ``python -m derive`` prints from the model's derivation (each phase's
accelerations, energy, body positions and skeleton; each event's guard, ``when`` and
reset; the failures' guards; the step length), and the model's hybrid descriptor as data.
It draws each phase's skeleton and bodies as ``vsw animate`` does, the view following the
walker along the ground (``window.vswPicture(t)``: what the canvas shows at time ``t``). In the
browser it integrates the walk (classical Runge-Kutta at a fixed step :data:`STEP`, guards
located by bisection to the last bit of time) and finds the period-one gait by Newton's method on
the step map from the gait vsw found at the start values (the runtime's search), then
follows it as the sliders move. No number is typed in, nothing is fetched.

A powered gait (``vsw explore --gait FILE``) is not integrated in the page: vsw replays its
inputs (:func:`vsw.studies.gait_file.replay_frames`) and the page plays the sampled states of that
step, one step after another, its sliders fixed at the gait's parameters.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vsw.runtime.errors import VswInputError

__all__ = ["STEP", "check_html_path", "page", "write_html", "write_page"]

TEMPLATE = Path(__file__).resolve().parent / "templates" / "explore_hybrid.html"
STEP = 2.5e-4
"""The page's Runge-Kutta step, in model time units (its state error ~1e-12 a step)."""
INTEGRATED = "\n".join([
    "Every number on this page is computed in your browser by",
    "JavaScript that <code>python -m derive</code> generated from the model's derivation",
    "(@@generated_from@@: each phase's accelerations, the events' guards and resets); the page",
    "integrates the walk (classical Runge&ndash;Kutta, step @@h@@, events located to",
    "the last bit of time) and finds the period-one gait by Newton's method on the step map, "
    "from the gait",
    "vsw found at the start values.",
])  # fmt: skip
"""How the page computes what it shows (a passive walk)."""
REPLAYED = """<strong>A powered gait, replayed.</strong> The walk on this page is the step vsw
simulated with the gait's inputs (SciPy DOP853, 1e-11), played one step after another; the
page draws it by JavaScript that <code>python -m derive</code> generated from the model's
derivation (@@generated_from@@: each phase's skeleton and bodies), integrates nothing, and
keeps its sliders at the gait's parameters."""
"""How the page of a replayed powered gait shows it."""


SLIDER_STEPS = 1000
"""Grid steps across a slider, at least (more where a step would exceed :data:`FINE`)."""
FINE = 1e-3
"""A slider's step is at most this fraction of its start value (a slope of 0.5 degrees on
a slider to 90 degrees still moves by 0.0005 degrees a key press)."""
WIDE = 10.0
"""A slider without both bounds in the parameter table spans value / WIDE to value * WIDE."""


def _slider(p: Any, value: float) -> dict[str, Any]:
    """A parameter's slider (angles in degrees): across the parameter table's open interval
    where both its ends are finite (inside what vsw computes), else from a tenth to ten
    times the value; a grid of :data:`SLIDER_STEPS` steps or more (:data:`FINE`) through
    the value itself (a browser snaps a slider to min + k step: the start must be on it),
    strictly inside the interval."""
    low, high = p.computed or (p.lower, p.upper)
    if p.unit == "rad":
        value, low, high = math.degrees(value), math.degrees(low), math.degrees(high)
    if math.isfinite(p.lower) and math.isfinite(p.upper):
        want_low, want_high = low, high
    elif value:
        want_low, want_high = sorted((value / WIDE, value * WIDE))
    else:
        want_low, want_high = -1.0, 1.0
    step = (want_high - want_low) / SLIDER_STEPS
    step = min(step, FINE * abs(value)) if value else step
    digit = math.floor(math.log10(step)) - 2  # three significant digits, rounded down
    step = float(f"{math.floor(step / 10.0**digit)}e{digit}")
    inside = (math.floor((value - low) / step) - 1, math.floor((high - value) / step) - 1)
    below = max(0, min(math.floor((value - want_low) / step), inside[0]))
    above = max(0, min(math.floor((want_high - value) / step), inside[1]))
    return {
        "name": p.name,
        "description": p.description,
        "unit": p.unit,
        "min": value - below * step,
        "max": value + above * step,
        "step": step,
        "value": value,
    }


def spec(model: Any, params: Sequence[float], start: Sequence[float],
         replay: dict[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """What the page needs of the model beside its generated functions; ``replay``: a
    powered gait's sampled step (:func:`vsw.studies.gait_file.replay_frames`), played instead of
    integrated."""
    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    step_event = model.step_event
    return {
        "h": STEP,
        "maxSteps": int(200 / STEP),
        "coordinates": list(model.coordinates),
        "rates": list(model.rates),
        "parameters": [_slider(p, v) for p, v in zip(model.parameter_table, params)],
        "phases": [
            {
                "name": ph["name"],
                "failures": [list(f) for f in ph["failures"]],
                "startFailures": [list(f) for f in ph.get("start_failures", ())],
                "skeleton": ph["skeleton"],
            }
            for ph in model.phases
        ],
        "events": [
            {
                "name": e["name"],
                "source": e["source"],
                "target": e["target"],
                "direction": e["direction"],
                "when": e["when"],
                "ends_step": e["ends_step"],
                "guard": f"event_{e['name']}_guard",
                "reset_fn": f"event_{e['name']}_reset",
            }
            for e in model.events
        ],
        "start_phase": step_event["target"],
        "step_event": step_event["name"],
        "start_state": [float(v) for v in start],
        "units": units,
        "time_unit": model.units.get("time", ""),
        "length_unit": model.units.get("length", ""),
        "slope": model.slope(params),
        "playback": 1.0,
        **({} if replay is None else {"replay": replay}),
    }


def page(model: Any, params: Sequence[float], start: Sequence[float],
         replay: dict[str, Any] | None = None) -> str:  # fmt: skip
    """The page's HTML for ``model`` with the sliders at ``params`` and Newton's first
    guess ``start`` (a section state, e.g. the runtime's stable gait); with ``replay``, a
    powered gait's step played from its samples (:func:`spec`)."""
    js_path = Path(model.module.__file__).resolve().parent / "js" / f"{model.name}.js"
    if not js_path.is_file():
        raise VswInputError(
            f"vsw explore: generated/{model.name}/js is missing: run python -m derive"
        )
    js = js_path.read_text()
    data = json.dumps(spec(model, params, start, replay), sort_keys=True)
    if "</script" in js or "</script" in data:
        raise VswInputError("the explorer's script would end early ('</script' in it)")
    replacements = {
        "@@how@@": INTEGRATED if replay is None else REPLAYED,  # first: it holds others
        "@@title@@": model.title,
        "@@description@@": model.spec.get("description", model.title),
        "@@generated_from@@": f"generated/{model.name}/js/{model.name}.js",
        "@@h@@": f"{STEP:g} {model.units.get('time', '')}".strip(),
        "@@ground@@": "grey, along the slope" if model.slope(params) else "grey",
        "@@namespace@@": f"vsw_{model.name}",
        "@@spec@@": data,
        "@@model_js@@": js,
    }
    text = TEMPLATE.read_text()
    for key, value in replacements.items():
        text = text.replace(key, value)
    return text


def write_page(path: str, model: Any, params: Sequence[float], start: Sequence[float],
               replay: dict[str, Any] | None = None) -> Path:  # fmt: skip
    """Write the page of :func:`page` to ``path``."""
    check_html_path(path)
    return write_html(path, page(model, params, start, replay))


def check_html_path(path: str) -> Path:
    """``--out``, checked before any work: an .html file in an existing directory."""
    out = Path(path)
    if out.suffix.lower() not in (".html", ".htm"):
        raise VswInputError(f"--out {path}: the page must end in .html")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise VswInputError(f"--out {path}: the directory {parent} does not exist")
    return out


def write_html(path: str, text: str) -> Path:
    """Write an explorer page (one line naming ``path`` when it cannot be written)."""
    out = check_html_path(path)
    try:
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise VswInputError(f"--out {path}: cannot write: {exc.strerror or exc}") from None
    return out
