"""Writes tests/data/gaits.json: every passive model's period-one gaits at its default
parameters, as the gait search (vsw.gaits.search) finds them, in the search's order.

    python tests/data/make_gaits.py

The fixtures that walk from a model's gait read them (tests/conftest.py, committed_gaits)
and confirm them by a compiled step and a Newton solve instead of searching the model's
section again; the slow tier searches again and compares (tests/test_gaits.py). Run this
when a model's default parameters or its gaits change, or a passive model is added.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
GAITS_PATH = Path(__file__).with_name("gaits.json")


def searched(key: str) -> dict[str, Any]:
    """One model's default parameters by name and the gaits the search finds there."""
    from vsw.models import load

    model = load(key)
    params = model.parameters()
    found = model.search_gaits(params)
    names = [p.name for p in model.parameter_table]
    return {
        "parameters": dict(zip(names, (float(v) for v in params), strict=True)),
        "gaits": [o.to_dict() for o in found.gaits],
    }


def every_model() -> dict[str, Any]:
    """The file's content: the gaits of every passive model (tests.conftest.passive_keys)."""
    from tests.conftest import passive_keys

    return {"models": {key: searched(key) for key in passive_keys()}}


def main() -> int:
    text = json.dumps(every_model(), indent=1) + "\n"
    GAITS_PATH.write_text(text)
    print(f"wrote {GAITS_PATH.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))  # tests.conftest and vsw from this checkout
    raise SystemExit(main())
