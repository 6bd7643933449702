"""The models the engine derives; each module holds one model's facts and derivation."""

from derive.models import ile, rimless_wheel, tle

MODELS = {"ile": ile.derive, "rimless_wheel": rimless_wheel.derive, "tle": tle.derive}
"""Model name (its ``generated/<name>/`` package) -> callable returning its
:class:`derive.quantities.Derivation`."""
