"""The ILE as a model of the runtime, answered by its closed forms where it has them.

:class:`IleModel` is the generic :class:`~vsw.models.base.Model` of the ILE's generated
package (its engine part: phases, events, failures) whose :meth:`~IleModel.analyze` comes
from the paper's closed forms instead of a search: the fixed point (10), the eigenvalue
(19), the existence conditions (12)-(17), the energies (20), (21), the step period in
Carlson form. Its report keeps every key of :func:`vsw.models.ile.analysis.analyze`'s
JSON and adds the generic ones (``fixed_points`` with each condition's margin, ``reason``),
so the ILE's outputs are those of every model plus its own. The other ILE-only features
(:data:`~vsw.models.base.FEATURES`): SI results, the closed-form basin and sweep, the
simulation figure, design and the explorer.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar

from generated import ile
from vsw.dynamics.hybrid import Orbit
from vsw.models.base import GaitReport, Model, Start
from vsw.models.ile import plots
from vsw.models.ile.analysis import Analysis, analyze
from vsw.models.ile.explore import write_page
from vsw.models.ile.params import STEPPER_2D, RobotScale
from vsw.models.ile.simulate import simulate
from vsw.plots.figures import save_figure
from vsw.runtime.errors import VswInputError

__all__ = ["IleModel"]


class IleModel(Model):
    """The instantaneous leg extension model: the generic runtime plus its closed forms."""

    features = frozenset(
        {"scale", "parameter-basin", "closed-form-sweep", "simulation-plot", "design",
         "explorer"}
    )  # fmt: skip

    routes: ClassVar[Mapping[str, str]] = MappingProxyType({
        "design": "vsw.cli.ile_design",
        "sweep": "vsw.cli.ile_sweep",
        "basin": "vsw.cli.ile_basin",
    })  # fmt: skip
    """The ILE's own routes of ``vsw design`` (closed forms over beta, theta_II, phi0),
    ``vsw sweep`` (closed forms at every value) and ``vsw basin`` without ``--grid`` (over
    theta_II and q0, Fig. 9)."""

    def robot_scale(
        self, leg_length: float | None, mass: float | None, gravity: float | None, preset: bool
    ) -> RobotScale | None:
        """The robot scale of ``--stepper-2d`` or ``--leg-length``/``--mass``/``--gravity``
        (SI results beside the model's units)."""
        if preset:
            if leg_length is not None or mass is not None:
                raise VswInputError(
                    "--stepper-2d sets the leg length and mass; drop --leg-length/--mass"
                )
            return STEPPER_2D if gravity is None else RobotScale(0.25, 0.78, gravity)
        if leg_length is None and mass is None:
            if gravity is not None:
                raise VswInputError("--gravity needs --leg-length and --mass (or --stepper-2d)")
            return None
        if leg_length is None or mass is None:
            raise VswInputError("--leg-length and --mass go together (SI results need both)")
        return RobotScale(leg_length, mass, 9.81 if gravity is None else gravity)

    def analyze(
        self,
        params: Sequence[float],
        box: Mapping[str, tuple[float, float]] | None = None,
        scale: RobotScale | None = None,
    ) -> GaitReport:
        """The closed-form analysis (:func:`vsw.models.ile.analysis.analyze`) as a report:
        its keys, and the gait (if the set walks) with every condition's margin."""
        if box:
            raise VswInputError("--search: the ile's gait is its closed-form fixed point (10); "
                                "there is nothing to search")  # fmt: skip
        result = analyze(*params, scale)
        margins = [_condition(c) for c in result.conditions]
        gaits, gait_margins, reason = [], [], None
        if bool(result.walks):
            gaits, gait_margins = [_gait(result)], [margins]
        else:
            failed = [m for m in margins if m["physical"] and not m["holds"]]
            text = "; ".join(f"{m['name']} {m['equation'] or ''} margin {m['margin']:.6g}"
                             f"{' ' + m['unit'] if m['unit'] else ''} ({m['meaning']})"
                             for m in failed)  # fmt: skip
            reason = (f"the fixed point q^f = {float(result.q_fixed):.6g} of (10) is no gait: "
                      f"{text}")  # fmt: skip
        data = result.to_dict()
        return GaitReport(gaits, gait_margins, reason=reason, extra=data, rows=_rows(data))

    def walk_keys(self, params: Sequence[float], walk: Any, start: Start) -> dict[str, Any]:
        """The generic keys and the ILE's own: its parameters, q0 and q after each step."""
        out = super().walk_keys(params, walk, start)
        return {**dict(zip(("beta", "theta_II", "phi0"), params)), "q0": out["q"][0], **out}

    def write_explorer(self, path: str, params: Sequence[float], **options: Any) -> Path:
        """The ILE's page of closed forms (:mod:`vsw.models.ile.explore`): sliders for beta,
        theta_II, phi0 and the robot's leg length (``leg_length``, m)."""
        beta, theta_II, phi0 = params
        leg = options.get("leg_length", 0.25)
        return write_page(path, beta=beta, theta_II_deg=math.degrees(theta_II),
                          phi0_deg=math.degrees(phi0), leg=leg)  # fmt: skip

    def save_simulation_plot(
        self, params: Sequence[float], start: Any, steps: int, path: str
    ) -> None:
        """theta, omega and q of the walk from ``start`` (:func:`plots.simulation_plot`)."""
        q0 = float(start[1]) ** 2
        result = simulate(*params, q0, steps, record=True)
        save_figure(plots.simulation_plot(*params, q0, steps, result), path)


def _rows(data: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """The text table of ``vsw analyze``: angles in degrees, units beside."""

    def degrees(value: float | None) -> float | None:
        return None if value is None else math.degrees(value)

    rows = [
        ("beta", data["beta"], ""),
        ("theta_II", degrees(data["theta_II"]), "deg"),
        ("phi0", degrees(data["phi0"]), "deg"),
        ("walks", data["walks"], ""),
        ("q_fixed", data["q_fixed"], "g/r_e"),
        ("omega_I", data["omega_I"], "sqrt(g/r_e)"),
        ("eigenvalue", data["eigenvalue"], ""),
        ("theta_I", degrees(data["theta_I"]), "deg"),
        ("theta_IV", degrees(data["theta_IV"]), "deg"),
        ("step_length", data["step_length"], "r_e"),
        ("step_period", data["step_period"], "sqrt(r_e/g)"),
        ("speed", data["speed"], "sqrt(g r_e)"),
        ("energy_added", data["energy_added"], data["energy_unit"]),
        ("energy_lost", data["energy_lost"], data["energy_unit"]),
        ("contact_margin", data["contact_margin"], "m g"),
        ("q_apex_min", data["q_apex_min"], "g/r_e"),
        ("q_liftoff_max", data["q_liftoff_max"], "g/r_e"),
    ]
    if "scale" in data:
        rows += [
            ("step_length_m", data["step_length_m"], "m"),
            ("step_period_s", data["step_period_s"], "s"),
            ("speed_m_s", data["speed_m_s"], "m/s"),
            ("speed_leg_s", data["speed_leg_s"], "leg/s"),
            ("energy_added_J", data["energy_added_J"], "J"),
            ("energy_lost_J", data["energy_lost_J"], "J"),
        ]
    return rows


def _condition(c: Any) -> dict[str, Any]:
    """A condition of :class:`~vsw.models.ile.analysis.Analysis` in the generic form."""
    return {
        "name": c.name,
        "equation": c.equation,
        "margin": float(c.value),
        "unit": c.unit,
        "holds": bool(c.holds),
        "physical": c.physical,
        "status": c.status,
        "meaning": c.meaning,
    }


def _gait(result: Analysis) -> Orbit:
    """The walking fixed point as a gait: the state just after heelstrike (theta_I and
    omega_I), the phases' durations (Carlson form), the eigenvalues of the map of the
    state (lambda (19) across the section's rate, 0 along it) and the step."""
    beta, theta_II, phi0 = (float(v) for v in (result.beta, result.theta_II, result.phi0))
    q_f = float(result.q_fixed)
    durations = tuple(float(v) for v in ile.phase_durations(beta, theta_II, phi0, q_f))
    return Orbit(
        state={"theta": float(result.theta_I), "theta_dot": math.sqrt(q_f)},
        durations=durations,
        period=float(result.step_period),
        eigenvalues=(complex(float(result.eigenvalue)), 0j),
        step_length=float(result.step_length),
        residual=0.0,
    )
