"""The models the engine derives, by name, without importing them.

Each entry names the module whose ``derive()`` returns the model's
:class:`~derive.quantities.Derivation`. Importing a model imports sympy (most of a second);
``python -m derive`` with nothing to derive must not pay that (:mod:`derive.manifest`).
"""

from __future__ import annotations

MODEL_MODULES: dict[str, str] = {
    "ile": "derive.models.ile",
    "rimless_wheel": "derive.models.rimless_wheel",
    "tle": "derive.models.tle",
    "simplest_walker": "derive.models.simplest_walker",
    "compass_gait": "derive.models.compass_gait",
    "vsw_biped": "derive.models.vsw_biped",
    "kneed_walker": "derive.models.kneed_walker",
    "torso_walker": "derive.models.torso_walker",
    "vsw_biped_fte": "derive.models.vsw_biped_fte",
    "vsw_biped_phi0": "derive.models.vsw_biped_phi0",
    "point_mass_biped": "derive.models.point_mass_biped",
    "point_mass_biped_switch": "derive.models.point_mass_biped_switch",
    "kuo_walker": "derive.models.kuo_walker",
    "level_compass_gait": "derive.models.level_compass_gait",
    "free_vsw_biped": "derive.models.free_vsw_biped",
    "free_vsw_biped_stop": "derive.models.free_vsw_biped_stop",
    "free_vsw_biped_push": "derive.models.free_vsw_biped_push",
    "three_link_biped": "derive.models.three_link_biped",
    "rabbit": "derive.models.rabbit",
}
"""Model name (its ``generated/<name>/`` package) -> module with its ``derive()``."""

MODEL_NAMES: tuple[str, ...] = tuple(MODEL_MODULES)

MODEL_GROUPS: tuple[tuple[str, ...], ...] = (
    ("ile", "tle"),
    ("vsw_biped", "vsw_biped_fte"),
    ("point_mass_biped", "point_mass_biped_switch"),
    ("free_vsw_biped", "free_vsw_biped_stop", "free_vsw_biped_push"),
)
"""Models with a phase of the same dynamics (coordinates, bodies, gravity, held values):
``python -m derive`` gives each group to one worker process, which derives the shared
dynamics once (the engine caches them per process). Scheduling only: each model's files
are the same however the models are grouped."""
