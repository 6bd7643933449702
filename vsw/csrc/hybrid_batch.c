/* The batch simulator of a hybrid walking model: many initial states, one call.
 *
 * Built by vsw/batch.py as one translation unit after a model's generated table
 * (generated/<model>/c/<model>_sim.c, written by `python -m derive`), which defines the
 * model's sizes (VSW_NP, VSW_NX, ...), its phases' flows and watched guards (its events'
 * guards, then its failures'), its events' resets, targets and `when` conditions, and the
 * step length. Nothing here knows a model.
 *
 * Each phase is integrated with the explicit DOP853 pair (adaptive step, SciPy's error
 * norm and step-size control) until one of its watched guards crosses zero in its
 * direction; the crossing is located by the Illinois method on the guard along the
 * accepted step's dense output (DOP853's 7th-order interpolant, as SciPy's), to a bracket
 * of VSW_EVENT_TIME_TOL in time. The rules are those of the project's SciPy route
 * (vsw.hybrid.HybridModel.step): a crossing counts when the guard goes from <= 0 to >= 0
 * (direction +1) or from >= 0 to <= 0 (direction -1); an event whose `when` is <= 0 does
 * not count and the phase goes on 1e-9 past it (at most 20 times); a failure whose guard
 * is already past zero at the phase start ends the walk there (a watched guard of direction
 * +2 or -2 is a failure checked there only, the sign its direction); a phase that lasts longer
 * than the phase time limit, or whose step shrinks below 10 ulps of the time, has stalled.
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "dop853_tableau.h"

/* The library's entry points; everything else is hidden (-fvisibility=hidden), so that the
   compiler may inline the model's functions into the loops instead of calling them
   through the procedure linkage table. */
#define VSW_EXPORT __attribute__((visibility("default")))

#define VSW_WALKED 0    /* every requested step, no class decided */
#define VSW_CONVERGED 1 /* within the tolerance of the given gait */
#define VSW_FELL 2      /* aux: the failure's index */
#define VSW_STALLED 3   /* a phase stalled, or the state left the finite numbers */
#define VSW_PERIODIC 4  /* aux: the period in steps */

#define VSW_EVENT_TIME_TOL 1e-13
#define VSW_RESTARTS 20
#define VSW_MAX_RK_STEPS 1000000L

typedef struct {
    double rtol, atol, phase_time_limit;
} vsw_tolerances;

/* Set from another thread when the run stops (Ctrl-C, the run-time limit: vsw/stop.py):
   every walk in progress ends as stalled at its next integrator step and none goes on,
   so a block ends within about one step; the caller discards its results. */
static volatile int vsw_stop_requested = 0;

VSW_EXPORT void vsw_batch_stop(int on)
{
    vsw_stop_requested = on;
}

/* Built with VSW_COUNT_CALLS (and _POSIX_C_SOURCE) defined (benchmark case 15 only), the
   integrator counts its flow and guard evaluations (plain counters: walk on one thread),
   and vsw_batch_call_costs times them alone: the floor of a step. */
#ifdef VSW_COUNT_CALLS
#include <time.h>
static long long vsw_flow_calls[VSW_NPHASES], vsw_watch_calls[VSW_NPHASES];
#define VSW_FLOW(phase, ...) (++vsw_flow_calls[phase], vsw_flow(phase, __VA_ARGS__))
#define VSW_WATCH(phase, ...) (++vsw_watch_calls[phase], vsw_watch(phase, __VA_ARGS__))

/* The evaluations since the last call, per phase: flows, then guards (a phase's at once). */
VSW_EXPORT void vsw_batch_counts(long long *out)
{
    for (int k = 0; k < VSW_NPHASES; ++k) {
        out[k] = vsw_flow_calls[k];
        out[VSW_NPHASES + k] = vsw_watch_calls[k];
        vsw_flow_calls[k] = vsw_watch_calls[k] = 0;
    }
}

static double vsw_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Seconds per evaluation of phase `phase`'s flow (out[0]) and guards (out[1]) over the
   n states given, `repeat` times each; out[2] the sum of every result (returned, so that
   the compiler computes each). */
VSW_EXPORT void vsw_batch_call_costs(int phase, const double *params, const double *states,
                                     long long n, long long repeat, double *out)
{
    double c[VSW_NC > 0 ? VSW_NC : 1], f[VSW_NX], g[VSW_MAX_WATCH], sum = 0.0;
    vsw_constants(params, c);
    double start = vsw_seconds();
    for (long long r = 0; r < repeat; ++r)
        for (long long i = 0; i < n; ++i) {
            vsw_flow(phase, c, states + i * VSW_NX, f);
            for (int k = 0; k < VSW_NX; ++k) sum += f[k]; /* every output is needed */
        }
    out[0] = (vsw_seconds() - start) / (double)(repeat * n);
    start = vsw_seconds();
    for (long long r = 0; r < repeat; ++r)
        for (long long i = 0; i < n; ++i) {
            vsw_watch(phase, c, states + i * VSW_NX, g);
            for (int k = 0; k < vsw_n_watch[phase]; ++k) sum += g[k];
        }
    out[1] = (vsw_seconds() - start) / (double)(repeat * n);
    out[2] = sum;
}
#else
#define VSW_FLOW vsw_flow
#define VSW_WATCH vsw_watch
#endif

/* C99's fmax and fmin (a NaN argument is ignored) as comparisons: GCC calls the library
   for them unless told that no NaN occurs, and a call costs more than the comparison. */
static inline double vsw_fmax(double a, double b)
{
    return (a >= b || b != b) ? a : b;
}

static inline double vsw_fmin(double a, double b)
{
    return (a <= b || b != b) ? a : b;
}

static int vsw_finite(const double *x)
{
    for (int i = 0; i < VSW_NX; ++i)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* RMS norm of x / scale (SciPy's norm(x) / sqrt(n)). */
static double vsw_rms(const double *x, const double *scale)
{
    double s = 0.0;
    for (int i = 0; i < VSW_NX; ++i) {
        double v = x[i] / scale[i];
        s += v * v;
    }
    return sqrt(s / VSW_NX);
}

/* One DOP853 step of size h from y (f0 = f(y)); K[0..12] the stages and f(y_new). */
static void vsw_rk_step(int phase, const double *p, const double *y, const double *f0, double h,
                        double K[VSW_RK_ALL][VSW_NX], double *y_new)
{
    double acc[VSW_NX];
    memcpy(K[0], f0, sizeof(double) * VSW_NX);
    /* Unrolled, the coefficients are constants and the zero ones (a quarter of the table)
       drop out: the same sums in the same order for finite stages. (GCC 12 keeps these
       sums scalar; a hand-vectorised version was slower: a store-to-load stall a stage.) */
#pragma GCC unroll 16
    for (int s = 1; s < VSW_RK_STAGES; ++s) {
        for (int i = 0; i < VSW_NX; ++i) acc[i] = 0.0;
#pragma GCC unroll 16
        for (int j = 0; j < s; ++j)
            if (vsw_rk_a[s][j] != 0.0)
                for (int i = 0; i < VSW_NX; ++i) acc[i] += K[j][i] * vsw_rk_a[s][j];
        for (int i = 0; i < VSW_NX; ++i) acc[i] = y[i] + acc[i] * h;
        VSW_FLOW(phase, p, acc, K[s]);
    }
    for (int i = 0; i < VSW_NX; ++i) acc[i] = 0.0;
#pragma GCC unroll 16
    for (int j = 0; j < VSW_RK_STAGES; ++j)
        if (vsw_rk_b[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) acc[i] += K[j][i] * vsw_rk_b[j];
    for (int i = 0; i < VSW_NX; ++i) y_new[i] = y[i] + h * acc[i];
    VSW_FLOW(phase, p, y_new, K[VSW_RK_STAGES]);
}

/* SciPy's error norm of DOP853 (scipy.integrate._ivp.rk.DOP853._estimate_error_norm). */
static double vsw_error_norm(double K[VSW_RK_ALL][VSW_NX], double h, const double *scale)
{
    double a5[VSW_NX], a3[VSW_NX], e5 = 0.0, e3 = 0.0;
    for (int i = 0; i < VSW_NX; ++i) a5[i] = a3[i] = 0.0;
#pragma GCC unroll 16
    for (int j = 0; j <= VSW_RK_STAGES; ++j) {
        if (vsw_rk_e5[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) a5[i] += K[j][i] * vsw_rk_e5[j];
        if (vsw_rk_e3[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) a3[i] += K[j][i] * vsw_rk_e3[j];
    }
    for (int i = 0; i < VSW_NX; ++i) {
        const double r5 = a5[i] / scale[i], r3 = a3[i] / scale[i];
        e5 += r5 * r5;
        e3 += r3 * r3;
    }
    if (e5 == 0.0 && e3 == 0.0) return 0.0;
    double denom = e5 + 0.01 * e3;
    return fabs(h) * e5 / sqrt(denom * VSW_NX);
}

/* SciPy's select_initial_step for an 8th-order method (error estimator order 7). */
static double vsw_initial_step(int phase, const double *p, const double *y, const double *f0,
                               const vsw_tolerances *tol)
{
    double scale[VSW_NX], y1[VSW_NX], f1[VSW_NX], df[VSW_NX];
    for (int i = 0; i < VSW_NX; ++i) scale[i] = tol->atol + fabs(y[i]) * tol->rtol;
    double d0 = vsw_rms(y, scale), d1 = vsw_rms(f0, scale);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > tol->phase_time_limit) h0 = tol->phase_time_limit;
    for (int i = 0; i < VSW_NX; ++i) y1[i] = y[i] + h0 * f0[i];
    VSW_FLOW(phase, p, y1, f1);
    for (int i = 0; i < VSW_NX; ++i) df[i] = f1[i] - f0[i];
    double d2 = vsw_rms(df, scale) / h0;
    double h1;
    if (d1 <= 1e-15 && d2 <= 1e-15)
        h1 = vsw_fmax(1e-6, h0 * 1e-3);
    else
        h1 = pow(0.01 / vsw_fmax(d1, d2), 1.0 / 8.0);
    double h = vsw_fmin(100.0 * h0, h1);
    return vsw_fmin(h, tol->phase_time_limit);
}

static int vsw_crossed(double g0, double g1, int direction)
{
    int up = g0 <= 0.0 && g1 >= 0.0, down = g0 >= 0.0 && g1 <= 0.0;
    return direction > 0 ? up : direction < 0 ? down : (up || down);
}

/* DOP853's dense output over the accepted step from y_old (time 0) to y_new (time h): its
   three extra stages into K[13..15] and the interpolant's coefficients F (SciPy's
   Dop853DenseOutput). */
static void vsw_dense(int phase, const double *p, const double *y_old, const double *y_new,
                      double h, double K[VSW_RK_ALL][VSW_NX], double F[7][VSW_NX])
{
    double dy[VSW_NX];
#pragma GCC unroll 4
    for (int s = 0; s < VSW_RK_EXTRA; ++s) {
        const int stage = VSW_RK_STAGES + 1 + s;
        for (int i = 0; i < VSW_NX; ++i) {
            double acc = 0.0;
#pragma GCC unroll 16
            for (int j = 0; j < stage; ++j)
                if (vsw_rk_a_extra[s][j] != 0.0) acc += K[j][i] * vsw_rk_a_extra[s][j];
            dy[i] = y_old[i] + acc * h;
        }
        VSW_FLOW(phase, p, dy, K[stage]);
    }
    for (int i = 0; i < VSW_NX; ++i) {
        const double delta = y_new[i] - y_old[i];
        F[0][i] = delta;
        F[1][i] = h * K[0][i] - delta;
        F[2][i] = 2.0 * delta - h * (K[VSW_RK_STAGES][i] + K[0][i]);
#pragma GCC unroll 4
        for (int r = 0; r < 4; ++r) {
            double acc = 0.0;
#pragma GCC unroll 16
            for (int j = 0; j < VSW_RK_ALL; ++j)
                if (vsw_rk_d[r][j] != 0.0) acc += vsw_rk_d[r][j] * K[j][i];
            F[3 + r][i] = h * acc;
        }
    }
}

/* The interpolant at the fraction x of the step. */
static void vsw_interpolate(const double F[7][VSW_NX], const double *y_old, double x,
                            double *out)
{
    for (int i = 0; i < VSW_NX; ++i) {
        double y = 0.0;
        for (int k = 6; k >= 0; --k) {
            y += F[k][i];
            y *= ((6 - k) % 2 == 0) ? x : 1.0 - x;
        }
        out[i] = y + y_old[i];
    }
}

/* The first zero of watched guard k on the dense output of the step [0, h]: s, and the
   state there (at the bracket's end past the crossing). */
static double vsw_locate(int phase, const double *p, const double F[7][VSW_NX],
                         const double *y_old, const double *y_new, double h, int k, double ga,
                         double gb, double *y_hit)
{
    double g[VSW_MAX_WATCH], ys[VSW_NX];
    double a = 0.0, b = h;
    int side = 0;
    if (ga == 0.0) { /* SciPy's brentq returns the bracket's start when it is a zero */
        memcpy(y_hit, y_old, sizeof(double) * VSW_NX);
        return 0.0;
    }
    memcpy(y_hit, y_new, sizeof(double) * VSW_NX);
    if (gb == 0.0) return h;
    for (int it = 0; it < 200 && b - a > VSW_EVENT_TIME_TOL; ++it) {
        double s = b - gb * (b - a) / (gb - ga);
        if (!(s > a && s < b)) s = 0.5 * (a + b);
        vsw_interpolate(F, y_old, s / h, ys);
        VSW_WATCH(phase, p, ys, g);
        double gs = g[k];
        if (gs == 0.0 || (gs > 0.0) == (gb > 0.0)) { /* past the crossing: the new end */
            b = s;
            gb = gs;
            memcpy(y_hit, ys, sizeof(double) * VSW_NX);
            if (gs == 0.0) break;
            if (side == 1) ga *= 0.5;
            side = 1;
        } else {
            a = s;
            ga = gs;
            if (side == -1) gb *= 0.5;
            side = -1;
        }
    }
    return b;
}

/* Integrate phase `phase` from y (time 0) to its first counting event or failure.
   Returns the watched index hit (>= 0) or -1 when the phase stalled; *t the phase time. */
static int vsw_run_phase(int phase, const double *p, double *y, double *t,
                         const vsw_tolerances *tol)
{
    double g0[VSW_MAX_WATCH], g1[VSW_MAX_WATCH], f0[VSW_NX], y_new[VSW_NX], scale[VSW_NX];
    double K[VSW_RK_ALL][VSW_NX], F[7][VSW_NX];
    const int n_watch = vsw_n_watch[phase];
    VSW_WATCH(phase, p, y, g0);
    for (int k = 0; k < n_watch; ++k) /* a failure already past at the start */
        if (vsw_watch_what[phase][k] < 0 && g0[k] * vsw_watch_direction[phase][k] > 0.0) {
            *t = 0.0;
            return k;
        }
    double time = 0.0;
    for (int restart = 0; restart < VSW_RESTARTS; ++restart) {
        VSW_FLOW(phase, p, y, f0);
        double h = vsw_initial_step(phase, p, y, f0, tol);
        int rejected = 0;
        long steps = 0;
        int skipped = 0;
        while (!skipped) {
            /* SciPy's RungeKutta._step_impl: at least 10 ulps of the time, then shrink on
               every rejection until accepted or below that. */
            if (time >= tol->phase_time_limit || ++steps > VSW_MAX_RK_STEPS
                || vsw_stop_requested) {
                *t = time;
                return -1;
            }
            const double min_step = 10.0 * (nextafter(time, INFINITY) - time);
            if (h < min_step) h = min_step;
            double factor;
            for (;;) {
                if (h < min_step) {
                    *t = time;
                    return -1;
                }
                if (h > tol->phase_time_limit - time) h = tol->phase_time_limit - time;
                vsw_rk_step(phase, p, y, f0, h, K, y_new);
                for (int i = 0; i < VSW_NX; ++i)
                    scale[i] = tol->atol + vsw_fmax(fabs(y[i]), fabs(y_new[i])) * tol->rtol;
                const double err = vsw_error_norm(K, h, scale);
                if (err < 1.0) {
                    factor = err == 0.0 ? 10.0 : vsw_fmin(10.0, 0.9 * pow(err, -1.0 / 8.0));
                    if (rejected) factor = vsw_fmin(1.0, factor);
                    rejected = 0;
                    break;
                }
                /* NaN or inf as SciPy's max(0.2, ...): fmax ignores a NaN, pow(inf) is 0 */
                h *= vsw_fmax(0.2, 0.9 * pow(err, -1.0 / 8.0));
                rejected = 1;
            }
            VSW_WATCH(phase, p, y_new, g1);
            double first = INFINITY, y_first[VSW_NX], y_k[VSW_NX];
            int hit = -1, dense = 0;
            for (int k = 0; k < n_watch; ++k) {
                const int direction = vsw_watch_direction[phase][k];
                if (direction == 2 || direction == -2) continue; /* checked at the start only */
                if (!vsw_crossed(g0[k], g1[k], direction)) continue;
                if (!dense) {
                    vsw_dense(phase, p, y, y_new, h, K, F);
                    dense = 1;
                }
                double s = vsw_locate(phase, p, F, y, y_new, h, k, g0[k], g1[k], y_k);
                if (s < first) {
                    first = s;
                    hit = k;
                    memcpy(y_first, y_k, sizeof(double) * VSW_NX);
                }
            }
            if (hit >= 0) {
                int what = vsw_watch_what[phase][hit];
                time += first;
                memcpy(y, y_first, sizeof(double) * VSW_NX);
                double when;
                if (what >= 0 && vsw_when(what, p, y, &when)) {
                    if (when <= 0.0) { /* not this one: go on just past it (NaN counts) */
                        double f[VSW_NX];
                        VSW_FLOW(phase, p, y, f);
                        for (int i = 0; i < VSW_NX; ++i) y[i] += 1e-9 * f[i];
                        time += 1e-9;
                        VSW_WATCH(phase, p, y, g0);
                        skipped = 1;
                        continue;
                    }
                }
                *t = time;
                return hit;
            }
            time += h;
            memcpy(y, y_new, sizeof(double) * VSW_NX);
            memcpy(f0, K[VSW_RK_STAGES], sizeof(double) * VSW_NX);
            memcpy(g0, g1, sizeof(double) * VSW_MAX_WATCH);
            h *= factor;
        }
    }
    *t = time;
    return -1;
}

/* One step of the Poincare map from the section state x, replaced by the next one when the
   step completes (VSW_WALKED) and kept as it was when the walk falls (VSW_FELL, *failure
   set) or stalls (VSW_STALLED); *duration and *length of the step. `visits` (NULL in the
   batch's walks): each phase visit's duration, in order, and *visits their number. */
static int vsw_step(const double *p, double *x, double *duration, double *length, int *failure,
                    const vsw_tolerances *tol, double *visit_durations, int *visits)
{
    int phase = VSW_START_PHASE;
    double y[VSW_NX];
    memcpy(y, x, sizeof(double) * VSW_NX);
    *duration = 0.0;
    *length = NAN;
    for (int visit = 0; visit <= VSW_NPHASES; ++visit) {
        double t = 0.0;
        int hit = vsw_run_phase(phase, p, y, &t, tol);
        *duration += t;
        if (visits) {
            visit_durations[visit] = t;
            *visits = visit + 1;
        }
        if (hit < 0) return VSW_STALLED;
        int what = vsw_watch_what[phase][hit];
        if (what < 0) {
            *failure = -1 - what;
            return VSW_FELL;
        }
        if (vsw_event_ends_step[what]) vsw_step_length(p, y, length);
        double y_new[VSW_NX];
        vsw_reset(what, p, y, y_new);
        memcpy(y, y_new, sizeof(double) * VSW_NX);
        if (!vsw_finite(y)) return VSW_STALLED;
        if (vsw_event_ends_step[what]) {
            memcpy(x, y, sizeof(double) * VSW_NX);
            return VSW_WALKED;
        }
        phase = vsw_event_target[what];
    }
    return VSW_STALLED;
}

static double vsw_distance(const double *a, const double *b)
{
    double d = 0.0;
    for (int i = 0; i < VSW_NX; ++i) d = vsw_fmax(d, fabs(a[i] - b[i]));
    return d;
}

static double vsw_scale(const double *a)
{
    double s = 1.0;
    for (int i = 0; i < VSW_NX; ++i) s = vsw_fmax(s, fabs(a[i]));
    return s;
}

#define VSW_MAX_PERIOD 64
#define VSW_APART 100.0 /* a period-k cycle's points: more than this x the tolerance apart */

/* The batch: trajectory i starts at states[i * VSW_NX ...] with parameters
   params[i * params_stride ...] and walks up to max_steps steps.
   options: rtol, atol, phase time limit, convergence tolerance (<= 0: none), period
   tolerance (<= 0: none); both relative to max(1, |state|_inf).
   target: the gait's section state (NULL: none). Converged: max |x - target| <= conv_tol *
   max(1, |target|). Period k (2 <= k <= max_period, or 1 without a target): the state
   repeats the one k steps before to the period tolerance while the states 1 .. k-1 steps
   before are more than VSW_APART times that away (a walk spiralling into a fixed point
   comes back near itself after a few steps too).
   Outputs per trajectory: outcome (VSW_*), aux (failure index or period), steps walked,
   the final section state, and the last `keep` section states with their step lengths and
   durations (rows of a trajectory that walked fewer steps are NaN). */
VSW_EXPORT void vsw_batch_simulate(long long n, const double *params, long long params_stride,
                        const double *states, const double *options, const double *target,
                        long long max_steps, long long max_period, long long keep, int *outcome,
                        int *aux, long long *steps, double *final, double *kept_states,
                        double *kept_lengths, double *kept_durations)
{
    vsw_tolerances tol = {options[0], options[1], options[2]};
    const double conv_tol = options[3], period_tol = options[4];
    if (max_period > VSW_MAX_PERIOD) max_period = VSW_MAX_PERIOD;
    for (long long i = 0; i < n; ++i) {
        /* The model's functions take its constants, computed here from the parameters
           once a walk (the table's vsw_constants); `p` below is that vector. */
        double constants[VSW_NC > 0 ? VSW_NC : 1];
        vsw_constants(params + i * params_stride, constants);
        const double *p = constants;
        double x[VSW_NX], history[VSW_MAX_PERIOD][VSW_NX];
        memcpy(x, states + i * VSW_NX, sizeof(double) * VSW_NX);
        int result = VSW_WALKED, extra = 0;
        long long walked = 0;
        if (keep > 0) {
            for (long long r = 0; r < keep; ++r) {
                for (int j = 0; j < VSW_NX; ++j) kept_states[(i * keep + r) * VSW_NX + j] = NAN;
                kept_lengths[i * keep + r] = NAN;
                kept_durations[i * keep + r] = NAN;
            }
        }
        if (!vsw_finite(x)) result = VSW_STALLED;
        const double target_scale = target ? vsw_scale(target) : 1.0;
        while (result == VSW_WALKED && walked < max_steps && !vsw_stop_requested) {
            if (max_period > 0) memcpy(history[walked % max_period], x, sizeof(double) * VSW_NX);
            double duration, length;
            int failure = 0;
            int ended = vsw_step(p, x, &duration, &length, &failure, &tol, NULL, NULL);
            if (ended == VSW_FELL) {
                result = VSW_FELL;
                extra = failure;
                break;
            }
            if (ended == VSW_STALLED) {
                result = VSW_STALLED;
                break;
            }
            ++walked;
            if (keep > 0) {
                /* a ring of the last `keep` steps, unrolled below */
                long long r = (walked - 1) % keep;
                memcpy(kept_states + (i * keep + r) * VSW_NX, x, sizeof(double) * VSW_NX);
                kept_lengths[i * keep + r] = length;
                kept_durations[i * keep + r] = duration;
            }
            if (target && conv_tol > 0.0 && vsw_distance(x, target) <= conv_tol * target_scale) {
                result = VSW_CONVERGED;
                break;
            }
            if (period_tol > 0.0 && max_period > 0) {
                double bound = period_tol * vsw_scale(x);
                for (long long k = target ? 2 : 1; k <= max_period && k <= walked; ++k) {
                    if (vsw_distance(x, history[(walked - k) % max_period]) > bound) continue;
                    /* a cycle's points are apart: near a fixed point every lag is small */
                    int apart = 1;
                    for (long long j = 1; j < k; ++j)
                        if (vsw_distance(x, history[(walked - j) % max_period]) <= VSW_APART * bound)
                            apart = 0;
                    if (apart) {
                        result = VSW_PERIODIC;
                        extra = (int)k;
                    }
                    break;
                }
            }
        }
        if (keep > 0 && walked > 0) { /* unroll the ring: oldest first, NaN rows last */
            long long filled = walked < keep ? walked : keep, start = walked % keep;
            if (walked < keep) start = 0;
            double tmp_states[VSW_NX];
            /* rotate left by `start` with the three-reversal method */
            long long lo[3] = {0, start, 0}, hi[3] = {start, filled, filled};
            for (int pass = 0; pass < 3; ++pass) {
                for (long long a = lo[pass], b = hi[pass] - 1; a < b; ++a, --b) {
                    double *sa = kept_states + (i * keep + a) * VSW_NX;
                    double *sb = kept_states + (i * keep + b) * VSW_NX;
                    memcpy(tmp_states, sa, sizeof(double) * VSW_NX);
                    memcpy(sa, sb, sizeof(double) * VSW_NX);
                    memcpy(sb, tmp_states, sizeof(double) * VSW_NX);
                    double t1 = kept_lengths[i * keep + a];
                    kept_lengths[i * keep + a] = kept_lengths[i * keep + b];
                    kept_lengths[i * keep + b] = t1;
                    t1 = kept_durations[i * keep + a];
                    kept_durations[i * keep + a] = kept_durations[i * keep + b];
                    kept_durations[i * keep + b] = t1;
                }
            }
        }
        outcome[i] = result;
        aux[i] = extra;
        steps[i] = walked;
        memcpy(final + i * VSW_NX, x, sizeof(double) * VSW_NX);
    }
}

/* One step from the section state `state` with parameters `params`, each phase visit's
   duration recorded (the periodic-orbit solver's guess of the phase durations and its
   confirmation, without the SciPy route): returns VSW_WALKED (`state` replaced by the next
   section state), VSW_FELL (*failure its index) or VSW_STALLED; durations[k] the k-th phase
   visit's duration (room for VSW_NPHASES + 1), *visits their number, *length the step's
   length (NaN for a model without one). options: rtol, atol, phase time limit, as
   vsw_batch_simulate's. */
VSW_EXPORT int vsw_batch_step_phases(const double *params, double *state, const double *options,
                                     double *durations, int *visits, int *failure,
                                     double *length)
{
    vsw_tolerances tol = {options[0], options[1], options[2]};
    double constants[VSW_NC > 0 ? VSW_NC : 1];
    vsw_constants(params, constants);
    double duration;
    *visits = 0;
    *failure = 0;
    *length = NAN;
    if (!vsw_finite(state)) return VSW_STALLED;
    return vsw_step(constants, state, &duration, length, failure, &tol, durations, visits);
}

/* The model's sizes, for the caller's check against its descriptor. */
VSW_EXPORT void vsw_batch_sizes(long long *out)
{
    out[0] = VSW_NP;
    out[1] = VSW_NX;
    out[2] = VSW_NPHASES;
    out[3] = VSW_NEVENTS;
}
