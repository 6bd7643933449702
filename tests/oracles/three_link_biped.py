"""A hand-written numeric three-link biped: the tests' oracle for ``three_link_biped`` and
its hybrid zero dynamics, sharing no code with ``derive/`` or ``vsw/``.

The model is Grizzle, Abba & Plestan 2001 (IEEE TAC 46(1), Section V) as Westervelt,
Grizzle, Chevallereau, Choi & Morris 2007 write it (Section 6.6.1): absolute angles ``q =
(theta1, theta2, theta3)`` from the vertical (stance leg, swing leg, both foot to hip, and
torso), ``D(q) q'' + C(q, q') q' + G(q) = B u`` with ``B = [-1 0; 0 -1; 1 1]`` up to the
torques' sign (here ``u`` does work along ``theta3 - theta1`` and ``theta3 - theta2``, so
``B = [-1 0; 0 -1; 1 1]`` exactly). The matrices below are typed in from the book's form,
not derived; the impact is the extended-coordinates rule of Grizzle et al. 2001, eqs.
(18)-(21), with the foot's Jacobian written by hand.

The zero dynamics are computed here from the unactuated row of the equations of motion,
not from the angular momentum: with ``B_perp = (1, 1, 1)`` (``B_perp B = 0``) and ``q =
q_d(theta)`` along the surface, ``alpha1 theta'' + alpha2 theta'^2 + alpha3 = 0`` with
``alpha1 = B_perp D q_d'``, ``alpha2 = B_perp (D q_d'' + C(q_d, q_d') q_d')``, ``alpha3 =
B_perp G`` (Westervelt et al. 2003, IEEE TAC 48(1), eq. (51) in this form); ``z =
theta'^2 / 2`` obeys ``dz/dtheta = -(2 alpha2 z + alpha3) / alpha1``, integrated by its
integrating factor with SciPy's adaptive Gauss-Kronrod quadrature.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad

DEFAULTS = {"m_h": 15.0, "m": 5.0, "m_t": 10.0, "r": 1.0, "l": 0.5, "g": 9.81}
"""Grizzle et al. 2001, Table I (g = 9.81)."""

B = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]])


def mass_matrix(q: np.ndarray, p: dict = DEFAULTS) -> np.ndarray:
    m, mh, mt, r, l = p["m"], p["m_h"], p["m_t"], p["r"], p["l"]
    c12, c13 = math.cos(q[0] - q[1]), math.cos(q[0] - q[2])
    return np.array([
        [(1.25 * m + mh + mt) * r**2, -0.5 * m * r**2 * c12, mt * r * l * c13],
        [-0.5 * m * r**2 * c12, 0.25 * m * r**2, 0.0],
        [mt * r * l * c13, 0.0, mt * l**2],
    ])  # fmt: skip


def coriolis(q: np.ndarray, qd: np.ndarray, p: dict = DEFAULTS) -> np.ndarray:
    m, mt, r, l = p["m"], p["m_t"], p["r"], p["l"]
    s12, s13 = math.sin(q[0] - q[1]), math.sin(q[0] - q[2])
    return np.array([
        [0.0, -0.5 * m * r**2 * s12 * qd[1], mt * r * l * s13 * qd[2]],
        [0.5 * m * r**2 * s12 * qd[0], 0.0, 0.0],
        [-mt * r * l * s13 * qd[0], 0.0, 0.0],
    ])  # fmt: skip


def gravity(q: np.ndarray, p: dict = DEFAULTS) -> np.ndarray:
    m, mh, mt, r, l, g = p["m"], p["m_h"], p["m_t"], p["r"], p["l"], p["g"]
    return np.array([
        -0.5 * g * (2 * mh + 3 * m + 2 * mt) * r * math.sin(q[0]),
        0.5 * g * m * r * math.sin(q[1]),
        -g * mt * l * math.sin(q[2]),
    ])  # fmt: skip


def accelerations(q, qd, u, p: dict = DEFAULTS) -> np.ndarray:
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    rhs = B @ np.asarray(u, float) - coriolis(q, qd, p) @ qd - gravity(q, p)
    return np.linalg.solve(mass_matrix(q, p), rhs)


def energy(q, qd, p: dict = DEFAULTS) -> float:
    m, mh, mt, r, l, g = p["m"], p["m_h"], p["m_t"], p["r"], p["l"], p["g"]
    qd = np.asarray(qd, float)
    height = g * r * math.cos(q[0]) * (1.5 * m + mh + mt)
    height += g * (-0.5 * m * r * math.cos(q[1]) + mt * l * math.cos(q[2]))
    return 0.5 * qd @ mass_matrix(q, p) @ qd + height


# --- the masses, their velocities, angular momentum and the impact ---------------------


def masses(p: dict = DEFAULTS) -> np.ndarray:
    """hip, stance leg, swing leg, torso."""
    return np.array([p["m_h"], p["m"], p["m"], p["m_t"]])


def jacobians(q, p: dict = DEFAULTS) -> np.ndarray:
    """d(x, y)/d(theta1, theta2, theta3, x_foot, y_foot) of each mass, (4, 2, 5), the
    stance foot at (x_foot, y_foot)."""
    r, l = p["r"], p["l"]
    c1, s1, c2, s2, c3, s3 = (f(a) for a in q for f in (math.cos, math.sin))
    hip = np.array([[r * c1, 0, 0, 1, 0], [-r * s1, 0, 0, 0, 1]])
    stance = np.array([[r / 2 * c1, 0, 0, 1, 0], [-r / 2 * s1, 0, 0, 0, 1]])
    swing = hip + np.array([[0, -r / 2 * c2, 0, 0, 0], [0, r / 2 * s2, 0, 0, 0]])
    torso = hip + np.array([[0, 0, l * c3, 0, 0], [0, 0, -l * s3, 0, 0]])
    return np.array([hip, stance, swing, torso])


def positions(q, p: dict = DEFAULTS) -> np.ndarray:
    """(x, y) of each mass, the stance foot at the origin (4, 2)."""
    r, l = p["r"], p["l"]
    hip = np.array([r * math.sin(q[0]), r * math.cos(q[0])])
    half = np.array([math.sin(q[1]), math.cos(q[1])]) * r / 2
    torso = hip + l * np.array([math.sin(q[2]), math.cos(q[2])])
    return np.array([hip, hip / 2, hip - half, torso])


def swing_foot(q, p: dict = DEFAULTS) -> np.ndarray:
    r = p["r"]
    return r * np.array([math.sin(q[0]) - math.sin(q[1]), math.cos(q[0]) - math.cos(q[1])])


def angular_momentum(q, qd, about, p: dict = DEFAULTS) -> float:
    """Angular momentum about the point ``about`` (clockwise positive: the direction in
    which every angle grows), the stance foot fixed at the origin."""
    pos = positions(q, p) - np.asarray(about, float)
    vel = jacobians(q, p)[:, :, :3] @ np.asarray(qd, float)
    return float(np.sum(masses(p) * (pos[:, 1] * vel[:, 0] - pos[:, 0] * vel[:, 1])))


def impact(q, qd, p: dict = DEFAULTS) -> tuple[np.ndarray, np.ndarray]:
    """The state after heelstrike (legs relabelled): the extended mass matrix ``D_e``, the
    swing foot's Jacobian ``E`` and ``[D_e -E^T; E 0] [qd_e+; F] = [D_e qd_e-; 0]``."""
    q = np.asarray(q, float)
    jac = jacobians(q, p)
    de = np.einsum("i,ijk,ijl->kl", masses(p), jac, jac)
    r = p["r"]
    e = np.array([
        [r * math.cos(q[0]), -r * math.cos(q[1]), 0, 1, 0],
        [-r * math.sin(q[0]), r * math.sin(q[1]), 0, 0, 1],
    ])  # fmt: skip
    lhs = np.block([[de, -e.T], [e, np.zeros((2, 2))]])
    rhs = np.concatenate([de @ np.concatenate([qd, [0.0, 0.0]]), [0.0, 0.0]])
    after = np.linalg.solve(lhs, rhs)[:3]
    swap = np.array([[0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
    return swap @ q, swap @ after


# --- virtual constraints and the restricted Poincare map ---------------------------------


def bezier(alpha: np.ndarray, s: float) -> tuple[float, float, float]:
    """A Bezier polynomial of degree len(alpha) - 1 and its first two derivatives in s."""
    alpha = np.asarray(alpha, float)
    deg = len(alpha) - 1

    def value(a: np.ndarray, n: int) -> float:
        return sum(a[k] * math.comb(n, k) * s**k * (1 - s) ** (n - k) for k in range(n + 1))

    d1 = deg * np.diff(alpha)
    d2 = (deg - 1) * np.diff(d1) if deg > 1 else np.zeros(1)
    return value(alpha, deg), value(d1, deg - 1), value(d2, deg - 2) if deg > 1 else 0.0


@dataclass
class Surface:
    """q_d(theta) with theta = theta1 and its first two derivatives in theta."""

    q: Callable[[float], np.ndarray]
    dq: Callable[[float], np.ndarray]
    ddq: Callable[[float], np.ndarray]
    theta_plus: float
    theta_minus: float


def mirror_surface(theta_plus: float = -math.pi / 8, torso: float = math.pi / 6) -> Surface:
    """theta2 = -theta1 + (theta1^2 - theta_plus^2)/2, theta3 held."""
    a2 = theta_plus**2
    return Surface(
        q=lambda t: np.array([t, -t + 0.5 * (t * t - a2), torso]),
        dq=lambda t: np.array([1.0, -1.0 + t, 0.0]),
        ddq=lambda t: np.array([0.0, 1.0, 0.0]),
        theta_plus=theta_plus,
        theta_minus=-theta_plus,
    )


def bezier_surface(alphas: np.ndarray, theta_plus: float, theta_minus: float) -> Surface:
    """theta2 and theta3 as Bezier polynomials (rows of ``alphas``) in s."""
    span = theta_minus - theta_plus

    def parts(t: float) -> np.ndarray:
        s = (t - theta_plus) / span
        return np.array([bezier(a, s) for a in alphas])  # (2, 3)

    def q(t):
        return np.array([t, *parts(t)[:, 0]])

    def dq(t):
        return np.array([1.0, *(parts(t)[:, 1] / span)])

    def ddq(t):
        return np.array([0.0, *(parts(t)[:, 2] / span**2)])

    return Surface(q, dq, ddq, theta_plus, theta_minus)


def mirror_bezier(degree: int, theta_plus: float = -math.pi / 8, torso: float = math.pi / 6):
    """The mirror constraints as Bezier coefficients of ``degree`` (exact: fitted at
    ``degree + 1`` points, the polynomial being of degree two in s)."""
    s = np.linspace(0.0, 1.0, degree + 1)
    basis = np.array([[math.comb(degree, k) * x**k * (1 - x) ** (degree - k)
                       for k in range(degree + 1)] for x in s])  # fmt: skip
    surface = mirror_surface(theta_plus, torso)
    thetas = theta_plus + s * (-2 * theta_plus)
    values = np.array([surface.q(t)[1:] for t in thetas])
    return np.linalg.solve(basis, values).T  # (2, degree + 1)


def invariant_bezier(alphas: np.ndarray, theta_plus: float, theta_minus: float,
                     p: dict = DEFAULTS) -> np.ndarray:  # fmt: skip
    """Westervelt et al. 2003 (Theorem 4's construction): alpha_0 the actuated coordinates
    just after the impact, alpha_1 = alpha_0 + (theta_minus - theta_plus)/M times their
    rate per unit rate of theta just after it; the others as given."""
    alphas = np.array(alphas, float)
    deg = alphas.shape[1] - 1
    surface = bezier_surface(alphas, theta_plus, theta_minus)
    q_after, qd_after = impact(surface.q(theta_minus), surface.dq(theta_minus), p)
    alphas[:, 0] = q_after[1:]
    alphas[:, 1] = q_after[1:] + (theta_minus - theta_plus) / deg * qd_after[1:] / qd_after[0]
    return alphas


@dataclass
class RestrictedMap:
    """z- = theta1'^2/2 just before impact: z-_{k+1} = slope z-_k + offset."""

    slope: float
    offset: float
    theta_dot_minus: float
    theta_dot_plus: float
    zeta_star: float


def restricted_map(surface: Surface, p: dict = DEFAULTS) -> RestrictedMap:
    def alphas(t: float) -> tuple[float, float, float]:
        q, dq, ddq = surface.q(t), surface.dq(t), surface.ddq(t)
        d = mass_matrix(q, p)
        a1 = np.sum(d @ dq)
        a2 = np.sum(d @ ddq + coriolis(q, dq, p) @ dq)
        return a1, a2, float(np.sum(gravity(q, p)))

    lo, hi = surface.theta_plus, surface.theta_minus
    opts = {"epsabs": 1e-15, "epsrel": 1e-13, "limit": 200}

    def exponent(t: float) -> float:
        return quad(lambda x: 2 * alphas(x)[1] / alphas(x)[0], lo, t, **opts)[0]

    total = exponent(hi)
    factor = math.exp(-total)

    def forcing(t: float) -> float:
        a1, _, a3 = alphas(t)
        return math.exp(exponent(t) - total) * (-a3 / a1)

    offset = quad(forcing, lo, hi, **opts)[0]
    # Through the impact: the angular momentum about the new stance foot after it (the
    # impact's own), divided by theta1's inertia on the surface there.
    q_minus, dq_minus = surface.q(hi), surface.dq(hi)
    q_plus, qd_plus = impact(q_minus, dq_minus, p)
    sigma_plus = angular_momentum(q_plus, qd_plus, (0.0, 0.0), p)
    rate_plus = sigma_plus / alphas(lo)[0]  # theta1' after, per unit theta1' before
    slope = factor * rate_plus**2
    z_star = offset / (1.0 - slope)
    rate_minus = math.sqrt(2 * z_star)
    sigma_minus = alphas(hi)[0] * rate_minus
    return RestrictedMap(slope, offset, rate_minus, rate_plus * rate_minus, sigma_minus**2 / 2)
