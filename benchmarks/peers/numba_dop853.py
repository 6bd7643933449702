"""A hand-written numba DOP853 walker: the peer case 15 measures the batch simulator against.

What a user would write in about 200 lines instead of using vsw: SciPy's DOP853 (its
tableau, error norm, step-size control and initial step), the events located on the
accepted step's 7th-order dense output by the Illinois method to 1e-13 in time, the same
rules as vsw/dynamics/csrc/hybrid_batch.c (an event whose ``when`` is <= 0 is skipped 1e-9 past
it; a failure already past zero at the phase start ends the walk), and the model's
equations typed by hand with sin and cos: the simplest walker, the compass gait and the
VSW biped (two phases a step, the extension between them). numba is an optional
benchmark peer: ``pip install numba``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.integrate._ivp import dop853_coefficients as dop

N_STAGES = dop.N_STAGES  # 12
A = np.ascontiguousarray(dop.A[:N_STAGES, :N_STAGES])
B = np.ascontiguousarray(dop.B)
E3 = np.ascontiguousarray(dop.E3)
E5 = np.ascontiguousarray(dop.E5)
D = np.ascontiguousarray(dop.D)
A_EXTRA = np.ascontiguousarray(dop.A[N_STAGES + 1 :])
N_ALL = N_STAGES + 1 + A_EXTRA.shape[0]  # 16

WALKED, FELL, STALLED = 0, 2, 3
PHASE_TIME_LIMIT = 100.0  # vsw.dynamics.hybrid's, as the batch simulator's
EVENT_TIME_TOL = 1e-13


def make_walker(
    flow,
    watch,
    n_watch: np.ndarray,
    directions: np.ndarray,
    what: np.ndarray,
    when,
    reset,
    targets: np.ndarray,
    ends_step: np.ndarray,
    nx: int,
):
    """A jitted ``walk(params, starts, steps, rtol, atol, final, walked, outcome)``.

    ``flow(phase, p, y, out)``, ``watch(phase, p, y, out)`` (a phase's guards),
    ``when(event, p, y)``, ``reset(event, p, y, out)``: njit functions. Per phase:
    ``n_watch`` guards, their ``directions`` (+-2: a failure checked at the phase's start
    only) and ``what`` (the event's index, or -1 for a failure); per event: the phase
    after (``targets``) and whether it ends the step (``ends_step``). Each step starts in
    phase 0."""
    n_phases = n_watch.size
    max_watch = directions.shape[1]

    @njit(cache=False, fastmath=False)
    def rms(x, scale):
        s = 0.0
        for i in range(nx):
            v = x[i] / scale[i]
            s += v * v
        return math.sqrt(s / nx)

    @njit
    def initial_step(phase, p, y, f0, rtol, atol):
        scale = np.empty(nx)
        y1 = np.empty(nx)
        f1 = np.empty(nx)
        for i in range(nx):
            scale[i] = atol + abs(y[i]) * rtol
        d0, d1 = rms(y, scale), rms(f0, scale)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, PHASE_TIME_LIMIT)
        for i in range(nx):
            y1[i] = y[i] + h0 * f0[i]
        flow(phase, p, y1, f1)
        for i in range(nx):
            f1[i] -= f0[i]
        d2 = rms(f1, scale) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        return min(min(100.0 * h0, h1), PHASE_TIME_LIMIT)

    @njit
    def rk_step(phase, p, y, f0, h, K, y_new, tmp):
        K[0, :] = f0
        for s in range(1, N_STAGES):
            for i in range(nx):
                acc = 0.0
                for j in range(s):
                    acc += K[j, i] * A[s, j]
                tmp[i] = y[i] + acc * h
            flow(phase, p, tmp, K[s])
        for i in range(nx):
            acc = 0.0
            for j in range(N_STAGES):
                acc += K[j, i] * B[j]
            y_new[i] = y[i] + h * acc
        flow(phase, p, y_new, K[N_STAGES])

    @njit
    def error_norm(K, h, scale):
        e5 = 0.0
        e3 = 0.0
        for i in range(nx):
            a5 = 0.0
            a3 = 0.0
            for j in range(N_STAGES + 1):
                a5 += K[j, i] * E5[j]
                a3 += K[j, i] * E3[j]
            a5 /= scale[i]
            a3 /= scale[i]
            e5 += a5 * a5
            e3 += a3 * a3
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * nx)

    @njit
    def dense(phase, p, y_old, y_new, h, K, F, tmp):
        for s in range(A_EXTRA.shape[0]):
            stage = N_STAGES + 1 + s
            for i in range(nx):
                acc = 0.0
                for j in range(stage):
                    acc += K[j, i] * A_EXTRA[s, j]
                tmp[i] = y_old[i] + acc * h
            flow(phase, p, tmp, K[stage])
        for i in range(nx):
            delta = y_new[i] - y_old[i]
            F[0, i] = delta
            F[1, i] = h * K[0, i] - delta
            F[2, i] = 2.0 * delta - h * (K[N_STAGES, i] + K[0, i])
            for r in range(4):
                acc = 0.0
                for j in range(N_ALL):
                    acc += D[r, j] * K[j, i]
                F[3 + r, i] = h * acc

    @njit
    def interpolate(F, y_old, x, out):
        for i in range(nx):
            y = 0.0
            for k in range(6, -1, -1):
                y += F[k, i]
                y *= x if (6 - k) % 2 == 0 else 1.0 - x
            out[i] = y + y_old[i]

    @njit
    def locate(phase, p, F, y_old, y_new, h, k, ga, gb, y_hit, g, ys):
        a, b = 0.0, h
        side = 0
        if ga == 0.0:
            y_hit[:] = y_old
            return 0.0
        y_hit[:] = y_new
        if gb == 0.0:
            return h
        for _ in range(200):
            if b - a <= EVENT_TIME_TOL:
                break
            s = b - gb * (b - a) / (gb - ga)
            if not (a < s < b):
                s = 0.5 * (a + b)
            interpolate(F, y_old, s / h, ys)
            watch(phase, p, ys, g)
            gs = g[k]
            if gs == 0.0 or (gs > 0.0) == (gb > 0.0):
                b, gb = s, gs
                y_hit[:] = ys
                if gs == 0.0:
                    break
                if side == 1:
                    ga *= 0.5
                side = 1
            else:
                a, ga = s, gs
                if side == -1:
                    gb *= 0.5
                side = -1
        return b

    @njit
    def crossed(g0, g1, direction):
        up = g0 <= 0.0 and g1 >= 0.0
        down = g0 >= 0.0 and g1 <= 0.0
        return up if direction > 0 else down

    @njit
    def run_phase(phase, p, y, rtol, atol):
        """The phase from y to its first counting event or failure: (watched index or -1)."""
        g0, g1, g = np.empty(max_watch), np.empty(max_watch), np.empty(max_watch)
        f0, y_new, scale = np.empty(nx), np.empty(nx), np.empty(nx)
        tmp, ys, y_k, y_first = np.empty(nx), np.empty(nx), np.empty(nx), np.empty(nx)
        K = np.empty((N_ALL, nx))
        F = np.empty((7, nx))
        watch(phase, p, y, g0)
        for k in range(n_watch[phase]):
            if what[phase, k] < 0 and g0[k] * directions[phase, k] > 0.0:
                return k
        time = 0.0
        for _restart in range(20):
            flow(phase, p, y, f0)
            h = initial_step(phase, p, y, f0, rtol, atol)
            rejected = False
            skipped = False
            while not skipped:
                if time >= PHASE_TIME_LIMIT:
                    return -1
                min_step = 10.0 * (np.nextafter(time, np.inf) - time)
                h = max(h, min_step)
                while True:
                    if h < min_step:
                        return -1
                    h = min(h, PHASE_TIME_LIMIT - time)
                    rk_step(phase, p, y, f0, h, K, y_new, tmp)
                    for i in range(nx):
                        scale[i] = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                    err = error_norm(K, h, scale)
                    if err < 1.0:
                        factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
                        if rejected:
                            factor = min(1.0, factor)
                        rejected = False
                        break
                    h *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
                    rejected = True
                watch(phase, p, y_new, g1)
                first, hit, have_dense = np.inf, -1, False
                for k in range(n_watch[phase]):
                    if abs(directions[phase, k]) == 2:  # checked at the start only
                        continue
                    if not crossed(g0[k], g1[k], directions[phase, k]):
                        continue
                    if not have_dense:
                        dense(phase, p, y, y_new, h, K, F, tmp)
                        have_dense = True
                    s = locate(phase, p, F, y, y_new, h, k, g0[k], g1[k], y_k, g, ys)
                    if s < first:
                        first, hit = s, k
                        y_first[:] = y_k
                if hit >= 0:
                    time += first
                    y[:] = y_first
                    if what[phase, hit] >= 0 and when(what[phase, hit], p, y) <= 0.0:
                        flow(phase, p, y, tmp)
                        for i in range(nx):
                            y[i] += 1e-9 * tmp[i]
                        time += 1e-9
                        watch(phase, p, y, g0)
                        skipped = True
                        continue
                    return hit
                time += h
                y[:] = y_new
                f0[:] = K[N_STAGES]
                g0[:] = g1
                h *= factor
        return -1

    @njit
    def walk(params, starts, steps, rtol, atol, final, walked, outcome):
        y = np.empty(nx)
        y_next = np.empty(nx)
        x = np.empty(nx)  # the section state the step starts from: kept if it falls
        for n in range(starts.shape[0]):
            y[:] = starts[n]
            result = WALKED
            count = 0
            while count < steps and result == WALKED:
                x[:] = y
                phase = 0
                done = False
                for _visit in range(n_phases + 1):
                    hit = run_phase(phase, params, y, rtol, atol)
                    if hit < 0:
                        result = STALLED
                        break
                    event = what[phase, hit]
                    if event < 0:
                        result = FELL
                        break
                    reset(event, params, y, y_next)
                    y[:] = y_next
                    if not np.all(np.isfinite(y)):
                        result = STALLED
                        break
                    if ends_step[event]:
                        done = True
                        break
                    phase = targets[event]
                if result == WALKED and not done:
                    result = STALLED
                if done:
                    count += 1
            final[n] = y if result == WALKED else x
            walked[n] = count
            outcome[n] = result

    return walk


# --- the simplest walker (Garcia et al. 1998), typed by hand ------------------------------


@njit
def _simplest_flow(p, y, out):
    gamma = p[0]
    theta, phi, theta_dot = y[0], y[1], y[2]
    s = math.sin(gamma + theta)
    out[0] = y[2]
    out[1] = y[3]
    out[2] = s
    out[3] = s + math.sin(phi) * (theta_dot * theta_dot - math.cos(gamma + theta))


@njit
def _simplest_watch(p, y, out):
    gamma = p[0]
    theta, phi, theta_dot = y[0], y[1], y[2]
    c = math.cos(theta)
    out[0] = 2.0 * theta - phi  # heelstrike: the swing foot reaches the slope (rising)
    out[1] = theta_dot  # fell-backward
    out[2] = c  # fell-forward
    out[3] = 0.5 * math.cos(gamma) + 0.5 * math.cos(gamma + 2.0 * theta) - c * theta_dot**2


@njit
def _simplest_when(p, y):
    return y[0]  # heelstrike counts with the stance leg past the normal (theta > 0)


@njit
def _simplest_reset(p, y, out):
    theta, phi, theta_dot = y[0], y[1], y[2]
    c = math.cos(phi)
    out[0] = theta - phi
    out[1] = -phi
    out[2] = c * theta_dot
    out[3] = c * theta_dot * (1.0 - c)


def _one_phase(flow, watch, when, reset):
    """A one-phase model's functions with the phase and event arguments the walker passes."""

    @njit
    def phase_flow(phase, p, y, out):
        flow(p, y, out)

    @njit
    def phase_watch(phase, p, y, out):
        watch(p, y, out)

    @njit
    def event_when(event, p, y):
        return when(p, y)

    @njit
    def event_reset(event, p, y, out):
        reset(p, y, out)

    return phase_flow, phase_watch, event_when, event_reset


ONE_PHASE_TABLE = (np.array([4]), np.array([[1, -1, -1, -1]]), np.array([[0, -1, -1, -1]]))
"""Watch order: the step's event, then the failures fell-backward, fell-forward and
lift-off (as the generated tables')."""


def simplest_walker():
    """The simplest walker's walk function."""
    flow, watch, when, reset = _one_phase(_simplest_flow, _simplest_watch, _simplest_when,
                                          _simplest_reset)  # fmt: skip
    return make_walker(flow, watch, *ONE_PHASE_TABLE, when, reset, np.array([0]),
                       np.array([True]), 4)  # fmt: skip


# --- the compass gait (Goswami, Thuilot and Espiau 1998), typed by hand --------------------
# Angles from the slope normal (theta: stance leg, psi: swing leg; from the vertical they
# are theta + gamma and psi + gamma). Goswami's M q'' + N q' + g = 0 with q = (swing,
# stance); tests/test_passive_walkers.py and this file's checks compare it with the
# derivation's flow, guards and reset.


@njit
def _compass_accelerations(p, y):
    m_h, m, a, b, gamma, g = p[0], p[1], p[2], p[3], p[4], p[5]
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    l = a + b
    c, s = math.cos(theta - psi), math.sin(theta - psi)
    m11, m12, m22 = m * b * b, -m * l * b * c, (m_h + m) * l * l + m * a * a
    r1 = -m * l * b * s * theta_dot * theta_dot - m * b * g * math.sin(psi + gamma)
    r2 = m * l * b * s * psi_dot * psi_dot + (m_h * l + m * a + m * l) * g * math.sin(theta + gamma)
    det = m11 * m22 - m12 * m12
    return (m11 * r2 - m12 * r1) / det, (m22 * r1 - m12 * r2) / det


@njit
def _compass_flow(p, y, out):
    theta_ddot, psi_ddot = _compass_accelerations(p, y)
    out[0] = y[2]
    out[1] = y[3]
    out[2] = theta_ddot
    out[3] = psi_ddot


@njit
def _compass_watch(p, y, out):
    m_h, m, a, b, gamma, g = p[0], p[1], p[2], p[3], p[4], p[5]
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    l = a + b
    theta_ddot, psi_ddot = _compass_accelerations(p, y)
    c = math.cos(theta)
    out[0] = psi + theta  # heelstrike: the swing foot reaches the slope (rising)
    out[1] = theta_dot  # fell-backward
    out[2] = c  # fell-forward
    # lift-off: the ground's normal force on the stance foot, in M g
    stance = theta_ddot * math.sin(theta) + theta_dot * theta_dot * c
    swing = psi_ddot * math.sin(psi) + psi_dot * psi_dot * math.cos(psi)
    out[3] = (-(m_h * l + m * a + m * l) * stance + m * b * swing
              + (m_h + 2 * m) * g * math.cos(gamma))  # fmt: skip


@njit
def _compass_reset(p, y, out):
    m_h, m, a, b = p[0], p[1], p[2], p[3]
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    l = a + b
    c = math.cos(psi - theta)
    # Angular momenta about the new contact (whole body) and the hip (the new swing leg):
    # Q+ qd+ = Q- qd-, q = (swing, stance), the legs swapping roles.
    q11, q12, q22 = -m * a * b, -m * a * b + (m_h * l * l + 2 * m * a * l) * c, -m * a * b
    h1, h2 = q11 * psi_dot + q12 * theta_dot, q22 * theta_dot
    p11, p12 = m * b * (b - l * c), m * l * (l - b * c) + m * a * a + m_h * l * l
    p21, p22 = m * b * b, -m * b * l * c
    det = p11 * p22 - p12 * p21
    swing_dot, stance_dot = (p22 * h1 - p12 * h2) / det, (p11 * h2 - p21 * h1) / det
    out[0] = psi
    out[1] = theta
    out[2] = stance_dot
    out[3] = swing_dot


def compass_gait():
    """The compass gait's walk function."""
    flow, watch, when, reset = _one_phase(_compass_flow, _compass_watch, _simplest_when,
                                          _compass_reset)  # fmt: skip
    return make_walker(flow, watch, *ONE_PHASE_TABLE, when, reset, np.array([0]),
                       np.array([True]), 4)  # fmt: skip


# --- the VSW biped (derive/models/vsw_biped.py), typed by hand ------------------------------
# Level ground, scaled units (lengths in l, masses in m_H, g = 1). theta, psi: the stance
# and swing legs' angles from the vertical, positive with the hip ahead of the foot; the
# stance leg r long (beta in phase short, 1 in phase long), each leg's mass mu at b from
# the hip, the swing foot beta below the hip. Lagrange's equations of
#   T = ((r^2 + mu (r - b)^2 + mu r^2) theta'^2 - 2 mu r b cos(theta - psi) theta' psi'
#        + mu b^2 psi'^2) / 2,   V = (r + mu (2 r - b)) cos(theta) - mu b cos(psi).


@njit
def _biped_mass_matrix(r, mu, b, theta, psi):
    return (r * r + mu * (r - b) * (r - b) + mu * r * r, -mu * r * b * math.cos(theta - psi),
            mu * b * b)  # fmt: skip


@njit
def _biped_accelerations(r, mu, b, y):
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    m11, m12, m22 = _biped_mass_matrix(r, mu, b, theta, psi)
    s = math.sin(theta - psi)
    r1 = mu * r * b * s * psi_dot * psi_dot + (r + mu * (2.0 * r - b)) * math.sin(theta)
    r2 = -mu * r * b * s * theta_dot * theta_dot - mu * b * math.sin(psi)
    det = m11 * m22 - m12 * m12
    return (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det


@njit
def _biped_flow(phase, p, y, out):
    r = p[0] if phase == 0 else 1.0
    theta_ddot, psi_ddot = _biped_accelerations(r, p[2], p[3], y)
    out[0] = y[2]
    out[1] = y[3]
    out[2] = theta_ddot
    out[3] = psi_ddot


@njit
def _biped_watch(phase, p, y, out):
    beta, theta_II, mu, b = p[0], p[1], p[2], p[3]
    r = beta if phase == 0 else 1.0
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    theta_ddot, psi_ddot = _biped_accelerations(r, mu, b, y)
    # the ground's normal force on the stance foot: the weight plus the masses' vertical
    # accelerations (hip and stance mass on the stance leg, swing mass b below the hip)
    stance = -(theta_ddot * math.sin(theta) + theta_dot * theta_dot * math.cos(theta))
    swing = psi_ddot * math.sin(psi) + psi_dot * psi_dot * math.cos(psi)
    normal = 1.0 + 2.0 * mu + (r + mu * (r - b) + mu * r) * stance + mu * b * swing
    if phase == 0:
        out[0] = theta - theta_II  # extension (rising)
    else:
        out[0] = math.cos(theta) - beta * math.cos(psi)  # heelstrike: the swing foot's height
    out[1] = theta_dot  # fell-backward
    out[2] = math.cos(theta)  # fell-forward
    out[3] = normal  # lift-off
    if phase == 0:
        out[4] = theta - theta_II  # extension-missed: past theta_II at the start


@njit
def _biped_when(event, p, y):
    if event == 1:
        return y[0] - y[1]  # heelstrike counts with the swing foot ahead of the stance foot
    return 1.0  # the extension always counts


@njit
def _biped_reset(event, p, y, out):
    beta, mu, b = p[0], p[2], p[3]
    theta, psi, theta_dot, psi_dot = y[0], y[1], y[2], y[3]
    if event == 0:  # extension: both generalised momenta kept, the stance leg beta -> 1
        m11, m12, m22 = _biped_mass_matrix(beta, mu, b, theta, psi)
        p1, p2 = m11 * theta_dot + m12 * psi_dot, m12 * theta_dot + m22 * psi_dot
        m11, m12, m22 = _biped_mass_matrix(1.0, mu, b, theta, psi)
        det = m11 * m22 - m12 * m12
        out[0], out[1] = theta, psi
        out[2] = (m22 * p1 - m12 * p2) / det
        out[3] = (m11 * p2 - m12 * p1) / det
        return
    # heelstrike: the angular momentum about the new contact (every mass) and that of the
    # trailing leg's mass about the hip kept; the legs swap roles, the new stance leg beta
    # long. Each momentum is linear in the rates: its coefficients from unit rates.
    before = _biped_momenta(1.0, beta, mu, b, theta, psi, theta_dot, psi_dot, 1)
    a = _biped_momenta(beta, beta, mu, b, psi, theta, 1.0, 0.0, 2)
    c = _biped_momenta(beta, beta, mu, b, psi, theta, 0.0, 1.0, 2)
    det = a[0] * c[1] - c[0] * a[1]
    out[0], out[1] = psi, theta
    out[2] = (before[0] * c[1] - c[0] * before[1]) / det
    out[3] = (a[0] * before[1] - before[0] * a[1]) / det


@njit
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@njit
def _biped_momenta(r, beta, mu, b, theta, psi, theta_dot, psi_dot, trailing):
    """Angular momentum about the contact that is (or becomes) the stance foot, and the
    trailing leg's mass's about the hip; ``trailing`` 1: the stance leg's mass (before
    heelstrike, the contact the swing foot beta below the hip), 2: the swing leg's (after,
    the contact the stance foot)."""
    hip_x, hip_y = r * math.sin(theta), r * math.cos(theta)
    v_hip_x, v_hip_y = r * theta_dot * math.cos(theta), -r * theta_dot * math.sin(theta)
    stance_x, stance_y = (r - b) * math.sin(theta), (r - b) * math.cos(theta)
    v_stance_x = (r - b) * theta_dot * math.cos(theta)
    v_stance_y = -(r - b) * theta_dot * math.sin(theta)
    swing_x, swing_y = hip_x - b * math.sin(psi), hip_y - b * math.cos(psi)
    v_swing_x = v_hip_x - b * psi_dot * math.cos(psi)
    v_swing_y = v_hip_y + b * psi_dot * math.sin(psi)
    if trailing == 1:
        cx, cy = hip_x - beta * math.sin(psi), hip_y - beta * math.cos(psi)
    else:
        cx, cy = 0.0, 0.0
    total = (_cross(hip_x - cx, hip_y - cy, v_hip_x, v_hip_y)
             + mu * _cross(stance_x - cx, stance_y - cy, v_stance_x, v_stance_y)
             + mu * _cross(swing_x - cx, swing_y - cy, v_swing_x, v_swing_y))  # fmt: skip
    if trailing == 1:
        leg = mu * _cross(stance_x - hip_x, stance_y - hip_y, v_stance_x, v_stance_y)
    else:
        leg = mu * _cross(swing_x - hip_x, swing_y - hip_y, v_swing_x, v_swing_y)
    return total, leg


def vsw_biped():
    """The VSW biped's walk function: phase short (0) then long (1); watch order as the
    generated table's (the phase's event, fell-backward, fell-forward, lift-off, and in
    short extension-missed, checked at the start only)."""
    return make_walker(
        _biped_flow, _biped_watch, np.array([5, 4]),
        np.array([[1, -1, -1, -1, 2], [-1, -1, -1, -1, 0]]),
        np.array([[0, -1, -1, -1, -1], [1, -1, -1, -1, 0]]), _biped_when, _biped_reset,
        np.array([1, 0]), np.array([False, True]), 4,
    )  # fmt: skip
