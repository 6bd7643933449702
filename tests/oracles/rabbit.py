"""RABBIT's mechanics written by hand from its published kinematics, in numpy: an oracle
for tests/test_rabbit.py that shares nothing with the derivation (no sympy, no generated
code).

Chevallereau et al. 2003 (IEEE Control Systems Magazine 23(5), the model's figure and
parameter table) and Westervelt et al. 2007 (its RABBIT model): five rigid links on a pinned stance
foot. With every link's angle ``q_i`` measured from the vertical, positive with its upper
end ahead of its lower end, each mass centre is a sum of link vectors ``a (sin q_i, cos
q_i)``: the stance tibia's ``l_t - p_t`` along itself; the stance femur's ``l_t`` along the
tibia and ``l_f - p_f`` along itself; the torso's, the swing femur's and the swing tibia's
from the hip (``l_t``, ``l_f`` along the stance leg) by ``+p_T`` along the torso, ``-p_f``
along the swing femur, and ``-l_f`` along it and ``-p_t`` along the swing tibia. A link
turns at ``-q_i'`` (counterclockwise positive). So the kinetic energy is ``q'^T M q' / 2``
with ``M_ij = sum_k m_k a_ki a_kj cos(q_i - q_j) + I_i delta_ij`` and the potential energy
``g sum_k m_k y_k``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Rabbit:
    """The parameter table's links (Chevallereau et al. 2003; Westervelt et al. 2007)."""

    m_torso: float = 12.0
    m_femur: float = 6.8
    m_tibia: float = 3.2
    i_torso: float = 1.33
    i_femur: float = 0.47
    i_tibia: float = 0.20
    l_femur: float = 0.4
    l_tibia: float = 0.4
    c_torso: float = 0.24
    c_femur: float = 0.11
    c_tibia: float = 0.24
    g: float = 9.81

    @property
    def masses(self) -> np.ndarray:
        """Stance tibia, stance femur, torso, swing femur, swing tibia."""
        return np.array([self.m_tibia, self.m_femur, self.m_torso, self.m_femur, self.m_tibia])

    @property
    def inertias(self) -> np.ndarray:
        return np.array([self.i_tibia, self.i_femur, self.i_torso, self.i_femur, self.i_tibia])

    def arms(self) -> np.ndarray:
        """``a[k, i]``: mass centre ``k`` is ``sum_i a[k, i] (sin q_i, cos q_i)``."""
        lt, lf = self.l_tibia, self.l_femur
        return np.array([
            [lt - self.c_tibia, 0, 0, 0, 0],
            [lt, lf - self.c_femur, 0, 0, 0],
            [lt, lf, self.c_torso, 0, 0],
            [lt, lf, 0, -self.c_femur, 0],
            [lt, lf, 0, -lf, -self.c_tibia],
        ])  # fmt: skip

    def positions(self, q: np.ndarray) -> np.ndarray:
        """Mass centres (5, 2) in the chart of the stance foot."""
        a = self.arms()
        return np.stack([a @ np.sin(q), a @ np.cos(q)], axis=1)

    def velocities(self, q: np.ndarray, u: np.ndarray) -> np.ndarray:
        a = self.arms()
        return np.stack([a @ (np.cos(q) * u), -(a @ (np.sin(q) * u))], axis=1)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        a = self.arms()
        weighted = (a * self.masses[:, None]).T @ a  # sum_k m_k a_ki a_kj
        return weighted * np.cos(q[:, None] - q[None, :]) + np.diag(self.inertias)

    def potential(self, q: np.ndarray) -> float:
        return float(self.g * self.masses @ self.positions(q)[:, 1])

    def energy(self, q: np.ndarray, u: np.ndarray) -> float:
        return float(0.5 * u @ self.mass_matrix(q) @ u) + self.potential(q)

    def swing_foot(self, q: np.ndarray) -> np.ndarray:
        lt, lf = self.l_tibia, self.l_femur
        arm = np.array([lt, lf, 0.0, -lf, -lt])
        return np.array([arm @ np.sin(q), arm @ np.cos(q)])

    def swing_foot_jacobian(self, q: np.ndarray) -> np.ndarray:
        lt, lf = self.l_tibia, self.l_femur
        arm = np.array([lt, lf, 0.0, -lf, -lt])
        return np.stack([arm * np.cos(q), -arm * np.sin(q)])

    def angular_momentum(self, q: np.ndarray, u: np.ndarray, about: np.ndarray) -> float:
        """About the point ``about`` of the chart (z, counterclockwise positive)."""
        r = self.positions(q) - about
        v = self.velocities(q, u)
        orbital = self.masses * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])
        return float(orbital.sum() - self.inertias @ u)

    def impact(self, q: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rigid impact of the swing foot of Westervelt et al. 2007 (chapter 3), on the
        extended coordinates ``(q, x, y)`` (the stance foot free at ``(x, y)``):
        ``M_e (v+ - v-) = E^T F`` and ``E v+ = 0``, ``E`` the swing foot's Jacobian.
        Returns the extended rates after, the impulse ``F`` and the relabelled state's
        rates (legs swapped, torso kept)."""
        n = len(q)
        m_total = self.masses.sum()
        a = self.arms()
        # The mass centres move with the free foot too: (x, y) adds to every one.
        j_rot = np.stack([a * np.cos(q), -a * np.sin(q)], axis=1)  # (5 bodies, 2, 5)
        m_e = np.zeros((n + 2, n + 2))
        m_e[:n, :n] = self.mass_matrix(q)
        coupling = np.einsum("k,kci->ic", self.masses, j_rot)  # (5, 2)
        m_e[:n, n:] = coupling
        m_e[n:, :n] = coupling.T
        m_e[n:, n:] = m_total * np.eye(2)
        e = np.zeros((2, n + 2))
        e[:, :n] = self.swing_foot_jacobian(q)
        e[:, n:] = np.eye(2)
        system = np.block([[m_e, -e.T], [e, np.zeros((2, 2))]])
        rhs = np.concatenate([m_e @ np.concatenate([u, [0.0, 0.0]]), [0.0, 0.0]])
        solution = np.linalg.solve(system, rhs)
        v_after, impulse = solution[: n + 2], solution[n + 2 :]
        swap = [4, 3, 2, 1, 0]
        return v_after, impulse, v_after[:n][swap]
