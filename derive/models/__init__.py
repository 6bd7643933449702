"""The models the engine derives; each module holds one model's facts and derivation."""

from derive.models import compass_gait, ile, rimless_wheel, simplest_walker, tle, vsw_biped

MODELS = {
    "ile": ile.derive,
    "rimless_wheel": rimless_wheel.derive,
    "tle": tle.derive,
    "simplest_walker": simplest_walker.derive,
    "compass_gait": compass_gait.derive,
    "vsw_biped": vsw_biped.derive,
}
"""Model name (its ``generated/<name>/`` package) -> callable returning its
:class:`derive.quantities.Derivation`."""
