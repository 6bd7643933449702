"""``python -m paper_check.walkers``: the compass-like VSW biped's leg-mass study and the
passive walkers' published numbers beside ours, as Markdown on stdout.

The paper's question (its future work): how do massive legs change Virtual Slope Walking?
For a few (beta, theta_II) the period-one gait is continued along mu = m / m_H from 1e-4
to 1 (b / l = 0.3) and each row gives the emergent inter-leg angle at heelstrike, the step
period, speed, the largest eigenvalue of the stride map and the energy the extension adds
per step (equal to what heelstrike dissipates on a periodic gait), with the ILE's fixed
point (10) at that angle for comparison.
"""

from __future__ import annotations

import math
import sys

import numpy as np

import generated.ile as ile
from vsw.errors import ConvergenceError
from vsw.hybrid import load

MUS = (1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3, 1.0)
STUDY = ((0.8, 0.1), (0.85, 0.05))


def _continue(m, values: dict, name: str, targets, orbit):
    """The gait continued from ``orbit`` through ``targets`` of parameter ``name``."""
    out = []
    for value in targets:
        params = m.parameters({**values, name: value})
        try:
            orbit = m.periodic_orbit(params, np.array(list(orbit.state.values())),
                                     orbit.durations)  # fmt: skip
        except ConvergenceError:
            out.append((value, None, params))
            break
        out.append((value, orbit, params))
    return out


def vsw_biped_study(out=sys.stdout) -> None:
    m = load("vsw_biped")
    out.write("## Compass-like VSW biped: leg mass ratio mu (b / l = 0.3)\n\n")
    out.write("| beta | theta_II | mu | phi at heelstrike (deg) | period | speed | "
              "max abs eigenvalue | energy added per step (m_H g l) | ILE q^f (10) at phi "
              "/ biped q |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n")  # fmt: skip
    for beta, theta_II in STUDY:
        values = {"beta": beta, "theta_II": theta_II}
        first = min(m.fixed_points(m.parameters({**values, "mu": 1e-2})), key=lambda o: o.period)
        down = _continue(m, values, "mu", [1e-2, 1e-3, 1e-4], first)
        up = _continue(m, values, "mu", [0.03, 0.1, 0.3, 1.0], first)
        rows = sorted(down + up, key=lambda r: r[0])
        for mu, orbit, params in rows:
            if orbit is None:
                out.write(f"| {beta} | {theta_II} | {mu:g} | no gait by continuation | | | | | |\n")
                continue
            s = orbit.state
            phi = s["psi"] - s["theta"]
            events = {e.name: e for e in m.step_events(params, np.array(list(s.values())))}
            q_ile = float(ile.q_fixed(beta, theta_II, phi))
            out.write(
                f"| {beta} | {theta_II} | {mu:g} | {math.degrees(phi):.3f} | {orbit.period:.4f} "
                f"| {orbit.speed:.4f} | {orbit.max_abs_eigenvalue:.4g} | "
                f"{events['extension'].energy_change:.5f} | {q_ile / s['omega'] ** 2:.6f} |\n"
            )
    out.write("\n")


def main() -> int:
    vsw_biped_study()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
