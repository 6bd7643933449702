"""The full-order closed loop: the model under the computed-torque controller that
enforces the virtual constraints, as a model of the generic runtime.

With ``y = a(q) - h(theta(q))`` (``a`` and ``theta`` affine: ``y_dot = J q_dot``, ``J = A -
h'(theta) c``) and the model's ``q'' = f(q, q') + B(q) u``, ``y'' = J f - h''(theta)
theta_dot^2 + J B u``, so (Westervelt et al. 2003, eq. (40); Isidori's input-output
linearisation)

    u = (L_g L_f y)^-1 (-L_f^2 y - K_p y - K_d y_dot),  L_g L_f y = J B,
                                                       L_f^2 y = J f - h'' theta_dot^2,

gives ``y'' + K_d y' + K_p y = 0``. The closed loop's accelerations (and the failure guards
that depend on the inputs, the ground reaction's) are written over the model's generated
functions on any backend (numpy, CasADi), so :class:`vsw.dynamics.hybrid.HybridModel` simulates it
with the model's events and :mod:`vsw.orbits` finds its periodic orbit and monodromy
matrix: no other simulation or Newton here.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import ModuleType
from typing import Any

from vsw.dynamics.hybrid import HybridModel
from vsw.synthesis.hzd.zero import Surface

__all__ = ["ClosedLoop", "determinant", "solve"]


def determinant(matrix: list[list[Any]]) -> Any:
    """By cofactors (any backend's scalars; small matrices: one per input)."""
    if len(matrix) == 1:
        return matrix[0][0]
    total = 0
    for j, entry in enumerate(matrix[0]):
        minor = [row[:j] + row[j + 1 :] for row in matrix[1:]]
        total = total + (-1) ** j * entry * determinant(minor)
    return total


def solve(matrix: list[list[Any]], rhs: list[Any]) -> list[Any]:
    """Cramer's rule on any backend's scalars."""
    det = determinant(matrix)
    out = []
    for j in range(len(rhs)):
        replaced = [[*row[:j], rhs[i], *row[j + 1 :]] for i, row in enumerate(matrix)]
        out.append(determinant(replaced) / det)
    return out


class ClosedLoop:
    """The computed-torque closed loop of ``model`` on ``surface`` with gains (kp, kd)."""

    def __init__(self, model: HybridModel, surface: Surface, kp: float, kd: float) -> None:
        self.model = model
        self.surface = surface
        self.kp, self.kd = float(kp), float(kd)
        self.phase = model.step_event["target"]
        self.n = model.n
        self.m = len(model.phases[model.phase_index[self.phase]]["inputs"])

    def parts(self, p: Sequence[Any], x: Sequence[Any]) -> tuple[list, list, list, list]:
        """(f, B as rows, J as rows, L_f^2 y) at a state (any backend)."""
        s, n, mod = self.surface, self.n, self.model.module
        q, qd = list(x[:n]), list(x[n:])
        theta = sum(float(c) * v for c, v in zip(s.phase_row, q)) + float(s.phase_offset)
        theta_dot = sum(float(c) * v for c, v in zip(s.phase_row, qd))
        _, dh, ddh = s.desired(theta)
        f = list(getattr(mod, f"{self.phase}_accelerations")(*p, *x))
        gains = list(getattr(mod, f"{self.phase}_input_gains")(*p, *x))
        b = [gains[i * self.m : (i + 1) * self.m] for i in range(n)]
        jac = [[float(s.controlled[i][j]) - dh[i] * float(s.phase_row[j]) for j in range(n)]
               for i in range(s.k)]  # fmt: skip
        lf2 = [sum(jac[i][j] * f[j] for j in range(n)) - ddh[i] * theta_dot**2
               for i in range(s.k)]  # fmt: skip
        return f, b, jac, lf2

    def decoupling(self, p: Sequence[Any], x: Sequence[Any]) -> list[list[Any]]:
        """L_g L_f y = J B."""
        _, b, jac, _ = self.parts(p, x)
        return [[sum(jac[i][k] * b[k][j] for k in range(self.n)) for j in range(self.m)]
                for i in range(self.surface.k)]  # fmt: skip

    def torques(self, p: Sequence[Any], x: Sequence[Any]) -> list[Any]:
        """The controller's u at a state (any backend)."""
        s, n = self.surface, self.n
        _f, b, jac, lf2 = self.parts(p, x)
        q, qd = list(x[:n]), list(x[n:])
        h, _, _ = s.desired(
            sum(float(c) * v for c, v in zip(s.phase_row, q)) + float(s.phase_offset)
        )
        y = [sum(float(s.controlled[i][j]) * q[j] for j in range(n)) + float(s.offsets[i]) - h[i]
             for i in range(s.k)]  # fmt: skip
        y_dot = [sum(jac[i][j] * qd[j] for j in range(n)) for i in range(s.k)]
        lglf = [[sum(jac[i][k] * b[k][j] for k in range(n)) for j in range(self.m)]
                for i in range(s.k)]  # fmt: skip
        rhs = [-lf2[i] - self.kp * y[i] - self.kd * y_dot[i] for i in range(s.k)]
        return solve(lglf, rhs)

    def accelerations(self, *args: Any) -> tuple:
        p, x = args[: -2 * self.n], args[-2 * self.n :]
        f, b, _, _ = self.parts(p, x)
        u = self.torques(p, x)
        return tuple(f[i] + sum(b[i][j] * u[j] for j in range(self.m)) for i in range(self.n))

    def module(self) -> ModuleType:
        """The model's generated package with the closed loop's accelerations and the
        failure guards that carry the inputs' gains (the ground reaction's)."""
        base = self.model.module
        out = ModuleType(base.__name__)
        out.__dict__.update({k: v for k, v in base.__dict__.items() if not k.startswith("__")})
        out.__name__ = base.__name__
        setattr(out, f"{self.phase}_accelerations", self.accelerations)
        record = self.model.phases[self.model.phase_index[self.phase]]
        for _, function, _ in record["failures"]:
            gains = getattr(base, f"{function}_input_gains", None)
            if gains is not None:
                setattr(out, function, self._guard(getattr(base, function), gains))
        return out

    def _guard(self, guard: Any, gains: Any) -> Any:
        def with_inputs(*args: Any) -> Any:
            p, x = args[: -2 * self.n], args[-2 * self.n :]
            u = self.torques(p, x)
            g = gains(*p, *x)
            g = list(g) if isinstance(g, tuple) else [g]
            return guard(*p, *x) + sum(gi * ui for gi, ui in zip(g, u))

        return with_inputs

    def hybrid(self) -> HybridModel:
        """The closed loop as a model of the generic runtime."""
        return HybridModel(self.module())
