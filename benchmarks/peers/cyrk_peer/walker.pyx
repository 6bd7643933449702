# distutils: language = c++
# cython: language_level=3, boundscheck=False, wraparound=False
# cython: cdivision=True, initializedcheck=False
"""The walkers of benchmarks/peers/numba_dop853.py through CyRK's C++ DOP853 (its Cython API).

Each phase of a step is one ``cysolve_ivp_noreturn`` call (DOP853, rtol, atol) from the
phase's start, the phase's guards given as CyRK events (``max_allowed`` 1: the first
crossing in the watched direction ends the integration, CyRK locating it by Brent's method
on the step's dense output), into one CyRK solution reused for every call. The rules are
the numba peer's (and vsw/csrc/hybrid_batch.c's): a failure already past zero at the phase
start ends the walk, a failure checked at the start only is not an event, an event whose
``when`` is <= 0 is skipped 1e-9 past it (a new integration from there, its own initial
step), a phase ends by the time limit 100. The equations of motion are the numba peer's,
typed again in C. Built by ``cyrk_peer.load()`` (Cython, into a cache directory).
"""

from libc.math cimport sin, cos, isfinite
from libcpp.vector cimport vector

from CyRK.cy.common cimport PreEvalFunc, DiffeqFuncType, MAX_STEP
from CyRK.cy.events cimport Event, EventFunc
from CyRK.cy.cysolver_api cimport cysolve_ivp_noreturn, WrapCySolverResult, ODEMethod
from CyRK.cy.cysolver_api cimport CySolverResult

cdef int WALKED = 0
cdef int FELL = 2
cdef int STALLED = 3
cdef double PHASE_TIME_LIMIT = 100.0
cdef int MAX_WATCH = 5
cdef int NX = 4

ctypedef double (*WhenFunc)(int, double*, double*) noexcept nogil
ctypedef void (*ResetFunc)(int, double*, double*, double*) noexcept nogil

cdef struct Model:
    int n_phases
    DiffeqFuncType flow[2]
    int n_watch[2]
    EventFunc watch[10]  # phase * MAX_WATCH + guard
    int direction[10]  # +-1 watched, +-2 a failure checked at the phase's start only
    int what[10]  # the event's index, or -1 for a failure
    WhenFunc when
    ResetFunc reset
    int target[2]
    bint ends_step[2]


# --- the simplest walker -------------------------------------------------------------------

cdef void simplest_flow(double* dy, double t, double* y, char* args,
                        PreEvalFunc pre) noexcept nogil:
    cdef double gamma = (<double*>args)[0]
    cdef double s = sin(gamma + y[0])
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = s
    dy[3] = s + sin(y[1]) * (y[2] * y[2] - cos(gamma + y[0]))

cdef double simplest_heelstrike(double t, double* y, char* args) noexcept nogil:
    return 2.0 * y[0] - y[1]

cdef double fell_backward(double t, double* y, char* args) noexcept nogil:
    return y[2]

cdef double fell_forward(double t, double* y, char* args) noexcept nogil:
    return cos(y[0])

cdef double simplest_lift_off(double t, double* y, char* args) noexcept nogil:
    cdef double gamma = (<double*>args)[0]
    return 0.5 * cos(gamma) + 0.5 * cos(gamma + 2.0 * y[0]) - cos(y[0]) * y[2] * y[2]

cdef double stance_past_normal(int event, double* p, double* y) noexcept nogil:
    return y[0]

cdef void simplest_reset(int event, double* p, double* y, double* out) noexcept nogil:
    cdef double c = cos(y[1])
    out[0] = y[0] - y[1]
    out[1] = -y[1]
    out[2] = c * y[2]
    out[3] = c * y[2] * (1.0 - c)


# --- the compass gait ----------------------------------------------------------------------

cdef inline void compass_accelerations(double* p, double* y, double* acc) noexcept nogil:
    cdef double m_h = p[0], m = p[1], a = p[2], b = p[3], gamma = p[4], g = p[5]
    cdef double l = a + b
    cdef double c = cos(y[0] - y[1]), s = sin(y[0] - y[1])
    cdef double m11 = m * b * b, m12 = -m * l * b * c, m22 = (m_h + m) * l * l + m * a * a
    cdef double r1 = -m * l * b * s * y[2] * y[2] - m * b * g * sin(y[1] + gamma)
    cdef double r2 = (m * l * b * s * y[3] * y[3]
                      + (m_h * l + m * a + m * l) * g * sin(y[0] + gamma))
    cdef double det = m11 * m22 - m12 * m12
    acc[0] = (m11 * r2 - m12 * r1) / det
    acc[1] = (m22 * r1 - m12 * r2) / det

cdef void compass_flow(double* dy, double t, double* y, char* args,
                       PreEvalFunc pre) noexcept nogil:
    cdef double acc[2]
    compass_accelerations(<double*>args, y, acc)
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = acc[0]
    dy[3] = acc[1]

cdef double compass_heelstrike(double t, double* y, char* args) noexcept nogil:
    return y[1] + y[0]

cdef double compass_lift_off(double t, double* y, char* args) noexcept nogil:
    cdef double* p = <double*>args
    cdef double m_h = p[0], m = p[1], a = p[2], b = p[3], gamma = p[4], g = p[5]
    cdef double l = a + b
    cdef double acc[2]
    compass_accelerations(p, y, acc)
    cdef double c = cos(y[0])
    cdef double stance = acc[0] * sin(y[0]) + y[2] * y[2] * c
    cdef double swing = acc[1] * sin(y[1]) + y[3] * y[3] * cos(y[1])
    return (-(m_h * l + m * a + m * l) * stance + m * b * swing
            + (m_h + 2 * m) * g * cos(gamma))

cdef void compass_reset(int event, double* p, double* y, double* out) noexcept nogil:
    cdef double m_h = p[0], m = p[1], a = p[2], b = p[3]
    cdef double theta = y[0], psi = y[1], theta_dot = y[2], psi_dot = y[3]
    cdef double l = a + b
    cdef double c = cos(psi - theta)
    cdef double q11 = -m * a * b, q12 = -m * a * b + (m_h * l * l + 2 * m * a * l) * c
    cdef double q22 = -m * a * b
    cdef double h1 = q11 * psi_dot + q12 * theta_dot, h2 = q22 * theta_dot
    cdef double p11 = m * b * (b - l * c), p12 = m * l * (l - b * c) + m * a * a + m_h * l * l
    cdef double p21 = m * b * b, p22 = -m * b * l * c
    cdef double det = p11 * p22 - p12 * p21
    out[0] = psi
    out[1] = theta
    out[2] = (p11 * h2 - p21 * h1) / det
    out[3] = (p22 * h1 - p12 * h2) / det


# --- the VSW biped -------------------------------------------------------------------------

cdef inline void biped_mass_matrix(double r, double mu, double b, double theta, double psi,
                                   double* out) noexcept nogil:
    out[0] = r * r + mu * (r - b) * (r - b) + mu * r * r
    out[1] = -mu * r * b * cos(theta - psi)
    out[2] = mu * b * b

cdef inline void biped_accelerations(double r, double mu, double b, double* y,
                                     double* acc) noexcept nogil:
    cdef double mm[3]
    biped_mass_matrix(r, mu, b, y[0], y[1], mm)
    cdef double s = sin(y[0] - y[1])
    cdef double r1 = mu * r * b * s * y[3] * y[3] + (r + mu * (2.0 * r - b)) * sin(y[0])
    cdef double r2 = -mu * r * b * s * y[2] * y[2] - mu * b * sin(y[1])
    cdef double det = mm[0] * mm[2] - mm[1] * mm[1]
    acc[0] = (mm[2] * r1 - mm[1] * r2) / det
    acc[1] = (mm[0] * r2 - mm[1] * r1) / det

cdef inline void biped_flow(double r, double* dy, double* y, double* p) noexcept nogil:
    cdef double acc[2]
    biped_accelerations(r, p[2], p[3], y, acc)
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = acc[0]
    dy[3] = acc[1]

cdef void biped_flow_short(double* dy, double t, double* y, char* args,
                           PreEvalFunc pre) noexcept nogil:
    biped_flow((<double*>args)[0], dy, y, <double*>args)

cdef void biped_flow_long(double* dy, double t, double* y, char* args,
                          PreEvalFunc pre) noexcept nogil:
    biped_flow(1.0, dy, y, <double*>args)

cdef inline double biped_normal(double r, double* y, double* p) noexcept nogil:
    cdef double mu = p[2], b = p[3]
    cdef double acc[2]
    biped_accelerations(r, mu, b, y, acc)
    cdef double stance = -(acc[0] * sin(y[0]) + y[2] * y[2] * cos(y[0]))
    cdef double swing = acc[1] * sin(y[1]) + y[3] * y[3] * cos(y[1])
    return 1.0 + 2.0 * mu + (r + mu * (r - b) + mu * r) * stance + mu * b * swing

cdef double biped_lift_off_short(double t, double* y, char* args) noexcept nogil:
    return biped_normal((<double*>args)[0], y, <double*>args)

cdef double biped_lift_off_long(double t, double* y, char* args) noexcept nogil:
    return biped_normal(1.0, y, <double*>args)

cdef double biped_extension(double t, double* y, char* args) noexcept nogil:
    return y[0] - (<double*>args)[1]

cdef double biped_heelstrike(double t, double* y, char* args) noexcept nogil:
    return cos(y[0]) - (<double*>args)[0] * cos(y[1])

cdef double biped_when(int event, double* p, double* y) noexcept nogil:
    if event == 1:
        return y[0] - y[1]
    return 1.0

cdef inline double cross(double ax, double ay, double bx, double by) noexcept nogil:
    return ax * by - ay * bx

cdef void biped_momenta(double r, double beta, double mu, double b, double theta, double psi,
                        double theta_dot, double psi_dot, int trailing,
                        double* out) noexcept nogil:
    cdef double hip_x = r * sin(theta), hip_y = r * cos(theta)
    cdef double v_hip_x = r * theta_dot * cos(theta), v_hip_y = -r * theta_dot * sin(theta)
    cdef double stance_x = (r - b) * sin(theta), stance_y = (r - b) * cos(theta)
    cdef double v_stance_x = (r - b) * theta_dot * cos(theta)
    cdef double v_stance_y = -(r - b) * theta_dot * sin(theta)
    cdef double swing_x = hip_x - b * sin(psi), swing_y = hip_y - b * cos(psi)
    cdef double v_swing_x = v_hip_x - b * psi_dot * cos(psi)
    cdef double v_swing_y = v_hip_y + b * psi_dot * sin(psi)
    cdef double cx = 0.0, cy = 0.0
    if trailing == 1:
        cx = hip_x - beta * sin(psi)
        cy = hip_y - beta * cos(psi)
    out[0] = (cross(hip_x - cx, hip_y - cy, v_hip_x, v_hip_y)
              + mu * cross(stance_x - cx, stance_y - cy, v_stance_x, v_stance_y)
              + mu * cross(swing_x - cx, swing_y - cy, v_swing_x, v_swing_y))
    if trailing == 1:
        out[1] = mu * cross(stance_x - hip_x, stance_y - hip_y, v_stance_x, v_stance_y)
    else:
        out[1] = mu * cross(swing_x - hip_x, swing_y - hip_y, v_swing_x, v_swing_y)

cdef void biped_reset(int event, double* p, double* y, double* out) noexcept nogil:
    cdef double beta = p[0], mu = p[2], b = p[3]
    cdef double theta = y[0], psi = y[1], theta_dot = y[2], psi_dot = y[3]
    cdef double mm[3]
    cdef double p1, p2, det
    cdef double before[2]
    cdef double ua[2]
    cdef double uc[2]
    if event == 0:  # extension: both generalised momenta kept, the stance leg beta -> 1
        biped_mass_matrix(beta, mu, b, theta, psi, mm)
        p1 = mm[0] * theta_dot + mm[1] * psi_dot
        p2 = mm[1] * theta_dot + mm[2] * psi_dot
        biped_mass_matrix(1.0, mu, b, theta, psi, mm)
        det = mm[0] * mm[2] - mm[1] * mm[1]
        out[0] = theta
        out[1] = psi
        out[2] = (mm[2] * p1 - mm[1] * p2) / det
        out[3] = (mm[0] * p2 - mm[1] * p1) / det
        return
    biped_momenta(1.0, beta, mu, b, theta, psi, theta_dot, psi_dot, 1, before)
    biped_momenta(beta, beta, mu, b, psi, theta, 1.0, 0.0, 2, ua)
    biped_momenta(beta, beta, mu, b, psi, theta, 0.0, 1.0, 2, uc)
    det = ua[0] * uc[1] - uc[0] * ua[1]
    out[0] = psi
    out[1] = theta
    out[2] = (before[0] * uc[1] - uc[0] * before[1]) / det
    out[3] = (ua[0] * before[1] - before[0] * ua[1]) / det


# --- the models' tables (as the numba peer's) -----------------------------------------------

cdef Model one_phase(DiffeqFuncType flow, EventFunc heelstrike, EventFunc lift_off,
                     ResetFunc reset) noexcept:
    cdef Model m
    m.n_phases = 1
    m.flow[0] = flow
    m.n_watch[0] = 4
    m.watch[0], m.watch[1] = heelstrike, fell_backward
    m.watch[2], m.watch[3] = fell_forward, lift_off
    m.direction[0], m.direction[1], m.direction[2], m.direction[3] = 1, -1, -1, -1
    m.what[0], m.what[1], m.what[2], m.what[3] = 0, -1, -1, -1
    m.when = stance_past_normal
    m.reset = reset
    m.target[0] = 0
    m.ends_step[0] = True
    return m

cdef Model biped() noexcept:
    cdef Model m
    m.n_phases = 2
    m.flow[0], m.flow[1] = biped_flow_short, biped_flow_long
    m.n_watch[0], m.n_watch[1] = 5, 4
    m.watch[0], m.watch[1], m.watch[2] = biped_extension, fell_backward, fell_forward
    m.watch[3], m.watch[4] = biped_lift_off_short, biped_extension
    m.direction[0], m.direction[1], m.direction[2], m.direction[3] = 1, -1, -1, -1
    m.direction[4] = 2
    m.what[0], m.what[1], m.what[2], m.what[3], m.what[4] = 0, -1, -1, -1, -1
    m.watch[5], m.watch[6], m.watch[7] = biped_heelstrike, fell_backward, fell_forward
    m.watch[8] = biped_lift_off_long
    m.direction[5], m.direction[6], m.direction[7], m.direction[8] = -1, -1, -1, -1
    m.what[5], m.what[6], m.what[7], m.what[8] = 1, -1, -1, -1
    m.when = biped_when
    m.reset = biped_reset
    m.target[0], m.target[1] = 1, 0
    m.ends_step[0], m.ends_step[1] = False, True
    return m


# --- the walker ----------------------------------------------------------------------------

cdef int run_phase(const Model* m, int phase, vector[char]& args, double* y, double rtol,
                   double atol, CySolverResult* solution, long long* calls) noexcept nogil:
    """The phase from y to its first counting event or failure: the guard's index, or -1
    (the time limit, or CyRK stopped without an event); y is left at the event."""
    cdef double* p = <double*>args.data()
    cdef int base = phase * MAX_WATCH
    cdef int k, hit, i, event
    cdef size_t last
    cdef double time = 0.0
    cdef double dy[4]
    cdef vector[double] y0 = vector[double](NX)
    cdef vector[Event] events
    cdef int guard[5]
    for k in range(m.n_watch[phase]):
        if m.what[base + k] < 0:  # a failure already past zero at the start
            if m.watch[base + k](0.0, y, args.data()) * m.direction[base + k] > 0.0:
                return k
    for k in range(m.n_watch[phase]):
        if m.direction[base + k] == 1 or m.direction[base + k] == -1:  # +-2: the start only
            guard[events.size()] = k
            events.push_back(Event(m.watch[base + k], 1, m.direction[base + k]))
    for _restart in range(20):
        if time >= PHASE_TIME_LIMIT:
            return -1
        for i in range(NX):
            y0[i] = y[i]
        cysolve_ivp_noreturn(solution, m.flow[phase], time, PHASE_TIME_LIMIT, y0, rtol, atol,
                             args, 0, 0, 2000, False, vector[double](), NULL, events)
        calls[0] += 1
        if not solution.event_terminated:
            return -1
        last = solution.size - 1
        time = solution.time_domain_vec[last]
        for i in range(NX):
            y[i] = solution.solution[last * NX + i]
        hit = guard[solution.event_terminate_index]
        event = m.what[base + hit]
        if event >= 0 and m.when(event, p, y) <= 0.0:
            m.flow[phase](dy, time, y, args.data(), NULL)
            for i in range(NX):
                y[i] += 1e-9 * dy[i]
            time += 1e-9
            continue
        return hit
    return -1


cdef long long walk_model(const Model* m, double[::1] params, double[:, ::1] starts, int steps,
                          double rtol, double atol, double[:, ::1] final, long long[::1] walked,
                          long long[::1] outcome, CySolverResult* solution) noexcept nogil:
    cdef vector[char] args = vector[char](params.shape[0] * sizeof(double))
    cdef double* p = <double*>args.data()
    cdef double y[4]
    cdef double y_next[4]
    cdef double x[4]
    cdef int n, i, phase, hit, event, result, count, visit
    cdef bint done, finite
    cdef long long calls = 0
    for i in range(params.shape[0]):
        p[i] = params[i]
    for n in range(starts.shape[0]):
        for i in range(NX):
            y[i] = starts[n, i]
        result = WALKED
        count = 0
        while count < steps and result == WALKED:
            for i in range(NX):
                x[i] = y[i]
            phase = 0
            done = False
            for visit in range(m.n_phases + 1):
                hit = run_phase(m, phase, args, y, rtol, atol, solution, &calls)
                if hit < 0:
                    result = STALLED
                    break
                event = m.what[phase * MAX_WATCH + hit]
                if event < 0:
                    result = FELL
                    break
                m.reset(event, p, y, y_next)
                finite = True
                for i in range(NX):
                    y[i] = y_next[i]
                    finite = finite and isfinite(y[i])
                if not finite:
                    result = STALLED
                    break
                if m.ends_step[event]:
                    done = True
                    break
                phase = m.target[event]
            if result == WALKED and not done:
                result = STALLED
            if done:
                count += 1
        for i in range(NX):
            final[n, i] = y[i] if result == WALKED else x[i]
        walked[n] = count
        outcome[n] = result
    return calls


cdef Model SIMPLEST = one_phase(simplest_flow, simplest_heelstrike, simplest_lift_off,
                                simplest_reset)
cdef Model COMPASS = one_phase(compass_flow, compass_heelstrike, compass_lift_off, compass_reset)
cdef Model BIPED = biped()


def walk(str key, double[::1] params, double[:, ::1] starts, int steps, double rtol,
         double atol, double[:, ::1] final, long long[::1] walked, long long[::1] outcome):
    """Walk each start ``steps`` steps (as numba_dop853's walk functions): the state after
    the last step (or the last step's start if it fell) into ``final``, the steps into
    ``walked``, 0 / 2 / 3 (walked / fell / stalled) into ``outcome``. Returns the number of
    CyRK integrations run."""
    cdef const Model* m
    if key == "simplest_walker":
        m = &SIMPLEST
    elif key == "compass_gait":
        m = &COMPASS
    elif key == "vsw_biped":
        m = &BIPED
    else:
        raise KeyError(key)
    cdef WrapCySolverResult holder = WrapCySolverResult()  # one solution, reused by every call
    holder.build_cyresult(ODEMethod.DOP853)
    cdef long long calls
    with nogil:
        calls = walk_model(m, params, starts, steps, rtol, atol, final, walked, outcome,
                           holder.cyresult_uptr.get())
    return calls
