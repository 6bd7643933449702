"""Whether an ILE parameter set walks, and the parameters of the paper's figures.

Shared by the audit (:mod:`paper_check.audit`) and its figures (:mod:`paper_check.figures`).
"""

from __future__ import annotations

import math

import numpy as np

from generated import ile

__all__ = ["FIG_BETA", "FIG_PHI0", "FIG_THETA_II", "failing_reason", "walk_mask"]

FIG_BETA, FIG_THETA_II, FIG_PHI0 = 0.8, 0.0, math.radians(45.0)
"""The parameters of the paper's Fig. 8 and 9."""


def walk_mask(beta: np.ndarray, theta_II: np.ndarray, phi0: np.ndarray) -> np.ndarray:
    """Every physical existence condition of the derivation holds (the gait walks)."""
    ok = np.ones(np.broadcast(beta, theta_II, phi0).shape, bool)
    for cond, margin in zip(ile.CONDITIONS, ile.condition_margins(beta, theta_II, phi0)):
        if cond[4]:
            m = np.asarray(margin, float)
            ok &= (m > 0) if cond[2] else (m >= 0)
    return ok


def failing_reason(beta: float, theta_II: float, phi0: float) -> str:
    """The physical conditions that fail, comma-separated ('none' when it walks)."""
    names = []
    for cond, margin in zip(ile.CONDITIONS, ile.condition_margins(beta, theta_II, phi0)):
        m = float(margin)
        if cond[4] and not ((m > 0) if cond[2] else (m >= 0)):
            names.append(cond[0])
    return ", ".join(names) or "none"
