/* The batch simulator of a hybrid walking model: many initial states, one call.
 *
 * Built by vsw/dynamics/batch.py as one translation unit after a model's generated table
 * (generated/<model>/c/<model>_sim.c, written by `python -m derive`), which defines the
 * model's sizes (VSW_NP, VSW_NX, ...), its phases' flows and watched guards (its events'
 * guards, then its failures'), its events' resets, targets and `when` conditions, and the
 * step length. Nothing here knows a model.
 *
 * Each phase is integrated with the explicit DOP853 pair (adaptive step, SciPy's error
 * norm and step-size control, its eighth roots by square roots) until one of its watched
 * guards crosses zero in its direction; the crossing is located by the Illinois method on
 * the guard along the accepted step's dense output (DOP853's 7th-order interpolant, as
 * SciPy's), to a bracket of VSW_EVENT_TIME_TOL in time. The rules are those of the
 * project's SciPy route (vsw.dynamics.hybrid.HybridModel.step): a crossing counts when the guard
 * goes from <= 0 to >= 0 (direction +1) or from >= 0 to <= 0 (direction -1); an event
 * whose `when` is <= 0 does not count and the phase goes on 1e-9 past it (at most 20
 * times); a failure whose guard is already past zero at the phase start ends the walk there
 * (a watched guard of direction +2 or -2 is a failure checked there only, the sign its
 * direction); a phase that lasts longer than the phase time limit, or whose step shrinks
 * below 10 ulps of the time, has stalled.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
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
    double max_step; /* the largest RK step (SciPy's max_step; INFINITY: unbounded) */
} vsw_tolerances;

/* The states a walk passes through, as SciPy's route samples them (HybridModel.simulate):
   each phase's start, each accepted RK step's end and each event's point twice (the
   solver's last point, then the event's). Samples past the capacity are counted, not
   written: the caller tries again with room for `count`. With `event` set, each event
   too: its index, time and the states before and after its reset (room for
   VSW_NPHASES + 1; `events` of them). */
typedef struct {
    double *t, *x;
    int *phase;
    long long capacity, count;
    int *event;
    double *event_time, *before, *after;
    int events;
} vsw_samples;

/* Set from another thread when the run stops (Ctrl-C, the run-time limit: vsw/runtime/stop.py):
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
static long long vsw_rk_calls[VSW_NPHASES]; /* RK steps, per walk */
#define VSW_FLOW(phase, ...) (++vsw_flow_calls[phase], vsw_flow(phase, __VA_ARGS__))
#define VSW_WATCH(phase, ...) (++vsw_watch_calls[phase], vsw_watch(phase, __VA_ARGS__))
/* One guard alone (event location) is not counted: the floor leaves those evaluations
   out, so it is below the cost of what a step evaluates. */
#define VSW_WATCH_ONE vsw_watch_one

/* The evaluations since the last call, per phase: flows, then guards (a phase's at once),
   then RK steps. */
VSW_EXPORT void vsw_batch_counts(long long *out)
{
    for (int k = 0; k < VSW_NPHASES; ++k) {
        out[k] = vsw_flow_calls[k];
        out[VSW_NPHASES + k] = vsw_watch_calls[k];
        out[2 * VSW_NPHASES + k] = vsw_rk_calls[k];
        vsw_flow_calls[k] = vsw_watch_calls[k] = vsw_rk_calls[k] = 0;
    }
}

static double vsw_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Seconds per evaluation of phase `phase`'s flow (out[0]) and guards (out[1]) over the
   n states given, `repeat` times each; the same per walk in lanes of VSW_LANES walks
   (out[3], out[4]); out[2] the sum of every result (returned, so that the compiler
   computes each). */
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
    /* the states in lanes before the clock starts (n >= VSW_LANES; else NaN) */
    const long long groups = n / VSW_LANES, all = (1 << VSW_LANES) - 1;
    /* aligned as a vector by hand (malloc's 16 bytes are not, and the vector loads would
       fault; aligned_alloc is not declared under this build's _POSIX_C_SOURCE) */
    char *raw = malloc(sizeof(vsw_lanes) * ((size_t)(groups > 0 ? groups : 1) * VSW_NX + 1));
    vsw_lanes *packed =
        raw ? (vsw_lanes *)(((uintptr_t)raw + sizeof(vsw_lanes) - 1)
                            & ~(uintptr_t)(sizeof(vsw_lanes) - 1))
            : NULL;
    out[3] = out[4] = NAN;
    if (groups > 0 && packed) {
        for (long long i = 0; i < groups; ++i)
            for (int k = 0; k < VSW_NX; ++k)
                for (int l = 0; l < VSW_LANES; ++l)
                    packed[i * VSW_NX + k][l] = states[(i * VSW_LANES + l) * VSW_NX + k];
        vsw_lanes cl[VSW_NC > 0 ? VSW_NC : 1], fl[VSW_NX], gl[VSW_MAX_WATCH];
        vsw_lanes total = vsw_lanes_splat(0.0);
        for (int k = 0; k < VSW_NC; ++k) cl[k] = vsw_lanes_splat(c[k]);
        for (int pass = 0; pass < 2; ++pass) {
            start = vsw_seconds();
            for (long long r = 0; r < repeat; ++r)
                for (long long i = 0; i < groups; ++i) {
                    if (pass == 0) {
                        vsw_lanes_flow(phase, all, cl, packed + i * VSW_NX, fl);
                        for (int k = 0; k < VSW_NX; ++k) total += fl[k];
                    } else {
                        vsw_lanes_watch(phase, all, cl, packed + i * VSW_NX, gl);
                        for (int k = 0; k < vsw_n_watch[phase]; ++k) total += gl[k];
                    }
                }
            out[3 + pass] = (vsw_seconds() - start) / (double)(repeat * groups * VSW_LANES);
        }
        for (int l = 0; l < VSW_LANES; ++l) sum += total[l];
    }
    free(raw);
    out[2] = sum;
}
#else
#define VSW_FLOW vsw_flow
#define VSW_WATCH vsw_watch
#define VSW_WATCH_ONE vsw_watch_one
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

/* x^(1/8) by three square roots (SciPy's step-size rule takes err ** (-1/8) and its initial
   step (0.01 / d) ** (1/8)): a few times cheaper than pow, which was a tenth of the
   simplest walker's step, and within an ulp or two of it (pow(x, 1/8) and this agree on
   0, inf and NaN). */
static inline double vsw_eighth_root(double x)
{
    return sqrt(sqrt(sqrt(x)));
}

/* The next double above t >= 0 minus t (nextafter(t, INFINITY) - t, without the call):
   the bit pattern of a non-negative double counts up with its value. */
static inline double vsw_ulp_above(double t)
{
    union {
        double d;
        uint64_t u;
    } next = {t};
    if (signbit(t) || !isfinite(t)) return nextafter(t, INFINITY) - t;
    next.u += 1;
    return next.d - t;
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

/* The table's flow (or guards) of phase `phase` on the lanes in `live` (a bit each), counted
   per walk in the counting build; the other lanes' results mean nothing. */
static inline void vsw_lanes_flow_in(int phase, int live, const vsw_lanes *c, const vsw_lanes *x,
                                     vsw_lanes *out)
{
#ifdef VSW_COUNT_CALLS
    vsw_flow_calls[phase] += __builtin_popcount((unsigned)live);
#endif
    vsw_lanes_flow(phase, live, c, x, out);
}

static inline void vsw_lanes_watch_in(int phase, int live, const vsw_lanes *c,
                                      const vsw_lanes *x, vsw_lanes *out)
{
#ifdef VSW_COUNT_CALLS
    vsw_watch_calls[phase] += __builtin_popcount((unsigned)live);
#endif
    vsw_lanes_watch(phase, live, c, x, out);
}

/* One DOP853 step of size h[l] from y (f0 = f(y)) on every lane: the stages and f(y_new) in
   K[0..12], y_new, and SciPy's error norm of the step
   (scipy.integrate._ivp.rk.DOP853._estimate_error_norm) in *err. Every lane is in phase
   `phase`; `live` lanes count (the others hold copies of a live lane's values). */
static void vsw_lanes_rk_step(int phase, int live, const vsw_lanes *c, const vsw_lanes *y,
                              const vsw_lanes *f0, vsw_lanes h, const vsw_tolerances *tol,
                              vsw_lanes K[VSW_RK_ALL][VSW_NX], vsw_lanes *y_new, vsw_lanes *err)
{
    vsw_lanes acc[VSW_NX];
    for (int i = 0; i < VSW_NX; ++i) K[0][i] = f0[i];
    /* Unrolled, the coefficients are constants and the zero ones (a quarter of the table)
       drop out: the same sums in the same order as the scalar code, on every lane. */
#pragma GCC unroll 16
    for (int s = 1; s < VSW_RK_STAGES; ++s) {
        for (int i = 0; i < VSW_NX; ++i) acc[i] = vsw_lanes_splat(0.0);
#pragma GCC unroll 16
        for (int j = 0; j < s; ++j)
            if (vsw_rk_a[s][j] != 0.0)
                for (int i = 0; i < VSW_NX; ++i) acc[i] += K[j][i] * vsw_rk_a[s][j];
        for (int i = 0; i < VSW_NX; ++i) acc[i] = y[i] + acc[i] * h;
        vsw_lanes_flow_in(phase, live, c, acc, K[s]);
    }
    for (int i = 0; i < VSW_NX; ++i) acc[i] = vsw_lanes_splat(0.0);
#pragma GCC unroll 16
    for (int j = 0; j < VSW_RK_STAGES; ++j)
        if (vsw_rk_b[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) acc[i] += K[j][i] * vsw_rk_b[j];
    for (int i = 0; i < VSW_NX; ++i) y_new[i] = y[i] + h * acc[i];
    vsw_lanes_flow_in(phase, live, c, y_new, K[VSW_RK_STAGES]);

    vsw_lanes a5[VSW_NX], a3[VSW_NX], e5 = vsw_lanes_splat(0.0), e3 = vsw_lanes_splat(0.0);
    for (int i = 0; i < VSW_NX; ++i) a5[i] = a3[i] = vsw_lanes_splat(0.0);
#pragma GCC unroll 16
    for (int j = 0; j <= VSW_RK_STAGES; ++j) {
        if (vsw_rk_e5[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) a5[i] += K[j][i] * vsw_rk_e5[j];
        if (vsw_rk_e3[j] != 0.0)
            for (int i = 0; i < VSW_NX; ++i) a3[i] += K[j][i] * vsw_rk_e3[j];
    }
    for (int i = 0; i < VSW_NX; ++i) {
        const vsw_lanes scale =
            tol->atol + vsw_lanes_fmax(vsw_lanes_fabs(y[i]), vsw_lanes_fabs(y_new[i])) * tol->rtol;
        const vsw_lanes r5 = a5[i] / scale, r3 = a3[i] / scale;
        e5 += r5 * r5;
        e3 += r3 * r3;
    }
    const vsw_lanes denom = e5 + 0.01 * e3;
    const vsw_lanes norm = vsw_lanes_fabs(h) * e5 / vsw_lanes_sqrt(denom * (double)VSW_NX);
    *err = vsw_lanes_select((e5 == 0.0) & (e3 == 0.0), vsw_lanes_splat(0.0), norm);
}

#ifdef VSW_COUNT_CALLS
/* Seconds per walk of one RK step of phase `phase` in lanes of VSW_LANES walks (its twelve
   flows, sums and error estimate: vsw_lanes_rk_step), each lane's steps chained as a walk
   chains them (y_new and its flow the next step's start) from the n states given (n >=
   VSW_LANES; else NaN), `repeat` steps of size h: out[0]; out[1] the sum of every result.
   The flows' counters tick inside the timed loop, as they do in the counted walks. */
VSW_EXPORT void vsw_batch_rk_cost(int phase, const double *params, const double *states,
                                  long long n, long long repeat, double h, double *out)
{
    const long long groups = n / VSW_LANES;
    const int all = (1 << VSW_LANES) - 1;
    const vsw_tolerances tol = {1e-10, 1e-10, INFINITY, INFINITY};
    double c[VSW_NC > 0 ? VSW_NC : 1];
    vsw_constants(params, c);
    vsw_lanes cl[VSW_NC > 0 ? VSW_NC : 1], y[VSW_NX], f0[VSW_NX], y_new[VSW_NX], err;
    vsw_lanes K[VSW_RK_ALL][VSW_NX], total = vsw_lanes_splat(0.0);
    for (int k = 0; k < VSW_NC; ++k) cl[k] = vsw_lanes_splat(c[k]);
    for (int k = 0; k < VSW_NX; ++k) y[k] = vsw_lanes_splat(0.0); /* read below if n < lanes */
    double seconds = 0.0;
    for (long long i = 0; i < groups; ++i) {
        for (int k = 0; k < VSW_NX; ++k)
            for (int l = 0; l < VSW_LANES; ++l) y[k][l] = states[(i * VSW_LANES + l) * VSW_NX + k];
        vsw_lanes_flow(phase, all, cl, y, f0);
        const double start = vsw_seconds();
        for (long long r = 0; r < repeat; ++r) {
            vsw_lanes_rk_step(phase, all, cl, y, f0, vsw_lanes_splat(h), &tol, K, y_new, &err);
            for (int k = 0; k < VSW_NX; ++k) {
                y[k] = y_new[k];
                f0[k] = K[VSW_RK_STAGES][k];
            }
            total += err;
        }
        seconds += vsw_seconds() - start;
    }
    for (int k = 0; k < VSW_NX; ++k) total += y[k];
    out[0] = groups > 0 ? seconds / (double)(repeat * groups * VSW_LANES) : NAN;
    out[1] = 0.0;
    for (int l = 0; l < VSW_LANES; ++l) out[1] += total[l];
}
#endif

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
        h1 = vsw_eighth_root(0.01 / vsw_fmax(d1, d2));
    double h = vsw_fmin(100.0 * h0, h1);
    return vsw_fmin(vsw_fmin(h, tol->phase_time_limit), tol->max_step);
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
    double ys[VSW_NX];
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
        const double gs = VSW_WATCH_ONE(phase, k, p, ys);
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

/* What a lane's phase code says after each of its moves: an RK step to take (VSW_READY),
   the phase stalled (VSW_PHASE_STALLED) or its watched guard k ended it (k >= 0). */
#define VSW_READY (-2)
#define VSW_PHASE_STALLED (-1)

/* One walk in a lane: what SciPy's route keeps between two RK steps (its integrator's
   step size, the phase's time and the guards at the current state), and the walk's
   bookkeeping. The integrator's rules are those of vsw.dynamics.hybrid.HybridModel.step, in the
   order the scalar integrator applied them (SciPy's RungeKutta._step_impl: the step at
   least 10 ulps of the time, shrunk on every rejection until accepted or below that). */
typedef struct {
    long long walk; /* its index in the batch; -1: the lane is empty */
    int phase, visit, restart, rejected;
    long steps; /* RK steps in this restart */
    double time, h, min_step, duration, length;
    double y[VSW_NX], f0[VSW_NX], g0[VSW_MAX_WATCH];
    double x[VSW_NX]; /* the section state the step started from */
    double constants[VSW_NC > 0 ? VSW_NC : 1];
    long long walked;
    double history[VSW_MAX_PERIOD][VSW_NX];
    double target_scale;
    vsw_samples *samples; /* where the walk's states are sampled, or NULL */
} vsw_lane;

/* The batch: its inputs, outputs and the next walk to start (see vsw_batch_simulate). */
typedef struct {
    long long n, params_stride, max_steps, max_period, keep, next;
    long long step_stride; /* > 0: step k of walk i takes params[i * params_stride +
                              k * step_stride ...] (its constants computed at the step
                              event); 0: one row for every step of a walk */
    const double *params, *states, *target;
    vsw_tolerances tol;
    double conv_tol, period_tol;
    int *outcome, *aux;
    long long *steps;
    double *final, *kept_states, *kept_lengths, *kept_durations;
    double *visit_durations; /* each phase visit's duration of walk 0's first step, or NULL */
    int *visits;
    vsw_samples *samples; /* walk 0's states sampled, or NULL */
} vsw_batch;

/* The lane's state y at its walk's time, as a sample (where the walk is sampled). */
static void vsw_sample(vsw_lane *ln, const double *y)
{
    vsw_samples *s = ln->samples;
    if (s == NULL) return;
    if (s->count < s->capacity) {
        s->t[s->count] = ln->duration + ln->time;
        memcpy(s->x + s->count * VSW_NX, y, sizeof(double) * VSW_NX);
        s->phase[s->count] = ln->phase;
    }
    ++s->count;
}

/* Before each RK step of the pass (the first, and again after each rejection). */
static int vsw_lane_try(const vsw_tolerances *tol, vsw_lane *ln)
{
    if (ln->h < ln->min_step) return VSW_PHASE_STALLED;
    if (ln->h > tol->phase_time_limit - ln->time) ln->h = tol->phase_time_limit - ln->time;
    return VSW_READY;
}

/* Before SciPy's `while` loop's next pass: stalled past the phase time limit, the RK
   steps' limit or a stop; else the step size at least 10 ulps of the time, and the pass's
   first RK step (vsw_lane_try). */
static int vsw_lane_top(const vsw_tolerances *tol, vsw_lane *ln)
{
    if (ln->time >= tol->phase_time_limit || ++ln->steps > VSW_MAX_RK_STEPS
        || vsw_stop_requested)
        return VSW_PHASE_STALLED;
    ln->min_step = 10.0 * vsw_ulp_above(ln->time);
    if (ln->h > tol->max_step)
        ln->h = tol->max_step;
    else if (ln->h < ln->min_step)
        ln->h = ln->min_step;
    return vsw_lane_try(tol, ln);
}

/* A fresh start of the integrator at the lane's state: f, SciPy's initial step. */
static int vsw_lane_restart(const vsw_tolerances *tol, vsw_lane *ln)
{
    VSW_FLOW(ln->phase, ln->constants, ln->y, ln->f0);
    ln->h = vsw_initial_step(ln->phase, ln->constants, ln->y, ln->f0, tol);
    ln->rejected = 0;
    ln->steps = 0;
    return vsw_lane_top(tol, ln);
}

/* The start of the lane's phase at its state: a failure already past there ends it. */
static int vsw_lane_phase_start(const vsw_tolerances *tol, vsw_lane *ln)
{
    VSW_WATCH(ln->phase, ln->constants, ln->y, ln->g0);
    ln->time = 0.0;
    ln->restart = 0;
    vsw_sample(ln, ln->y);
    for (int k = 0; k < vsw_n_watch[ln->phase]; ++k)
        if (vsw_watch_what[ln->phase][k] < 0
            && ln->g0[k] * vsw_watch_direction[ln->phase][k] > 0.0)
            return k;
    return vsw_lane_restart(tol, ln);
}

/* Lane l's RK step is done: err its error norm, K (every lane's stages; lane l's taken
   when an event needs the dense output), y_new and the guards g1 there. Accepted, the step
   either meets a counting event or failure (its watched index; the state there) or moves
   the lane on. */
static int vsw_lane_stepped(const vsw_tolerances *tol, vsw_lane *ln, int l, double err,
                            vsw_lanes K[VSW_RK_ALL][VSW_NX], const double *y_new, const double *g1)
{
    if (!(err < 1.0)) {
        /* NaN or inf as SciPy's max(0.2, ...): fmax ignores a NaN, 0.9 / inf is 0 */
        ln->h *= vsw_fmax(0.2, 0.9 / vsw_eighth_root(err));
        ln->rejected = 1;
        return vsw_lane_try(tol, ln);
    }
    double factor = err == 0.0 ? 10.0 : vsw_fmin(10.0, 0.9 / vsw_eighth_root(err));
    if (ln->rejected) factor = vsw_fmin(1.0, factor);
    ln->rejected = 0;
    const int phase = ln->phase, n_watch = vsw_n_watch[phase];
    const double *p = ln->constants;
    double first = INFINITY, y_first[VSW_NX], y_k[VSW_NX];
    double Kl[VSW_RK_ALL][VSW_NX], F[7][VSW_NX];
    int hit = -1, dense = 0;
    for (int k = 0; k < n_watch; ++k) {
        const int direction = vsw_watch_direction[phase][k];
        if (direction == 2 || direction == -2) continue; /* checked at the start only */
        if (!vsw_crossed(ln->g0[k], g1[k], direction)) continue;
        if (!dense) {
            for (int j = 0; j <= VSW_RK_STAGES; ++j)
                for (int i = 0; i < VSW_NX; ++i) Kl[j][i] = K[j][i][l];
            vsw_dense(phase, p, ln->y, y_new, ln->h, Kl, F);
            dense = 1;
        }
        double s = vsw_locate(phase, p, F, ln->y, y_new, ln->h, k, ln->g0[k], g1[k], y_k);
        if (s < first) {
            first = s;
            hit = k;
            memcpy(y_first, y_k, sizeof(double) * VSW_NX);
        }
    }
    if (hit >= 0) {
        const int what = vsw_watch_what[phase][hit];
        ln->time += first;
        memcpy(ln->y, y_first, sizeof(double) * VSW_NX);
        vsw_sample(ln, ln->y); /* the solver's last point, */
        vsw_sample(ln, ln->y); /* then the event's */
        double when;
        if (what >= 0 && vsw_when(what, p, ln->y, &when) && when <= 0.0) {
            /* not this one: go on just past it (NaN counts), with a fresh start */
            double f[VSW_NX];
            VSW_FLOW(phase, p, ln->y, f);
            for (int i = 0; i < VSW_NX; ++i) ln->y[i] += 1e-9 * f[i];
            ln->time += 1e-9;
            VSW_WATCH(phase, p, ln->y, ln->g0);
            if (++ln->restart >= VSW_RESTARTS) return VSW_PHASE_STALLED;
            return vsw_lane_restart(tol, ln);
        }
        return hit;
    }
    ln->time += ln->h;
    memcpy(ln->y, y_new, sizeof(double) * VSW_NX);
    vsw_sample(ln, ln->y);
    for (int i = 0; i < VSW_NX; ++i) ln->f0[i] = K[VSW_RK_STAGES][i][l];
    memcpy(ln->g0, g1, sizeof(double) * n_watch);
    ln->h *= factor;
    return vsw_lane_top(tol, ln);
}

/* The lane's walk ends: its outputs (the kept ring unrolled: oldest first, NaN rows last). */
static void vsw_lane_walk_end(vsw_batch *b, vsw_lane *ln, int result, int extra)
{
    const long long i = ln->walk, keep = b->keep, walked = ln->walked;
    if (keep > 0 && walked > 0) {
        long long filled = walked < keep ? walked : keep, start = walked % keep;
        if (walked < keep) start = 0;
        double tmp_states[VSW_NX];
        /* rotate left by `start` with the three-reversal method */
        long long lo[3] = {0, start, 0}, hi[3] = {start, filled, filled};
        for (int pass = 0; pass < 3; ++pass) {
            for (long long a = lo[pass], z = hi[pass] - 1; a < z; ++a, --z) {
                double *sa = b->kept_states + (i * keep + a) * VSW_NX;
                double *sz = b->kept_states + (i * keep + z) * VSW_NX;
                memcpy(tmp_states, sa, sizeof(double) * VSW_NX);
                memcpy(sa, sz, sizeof(double) * VSW_NX);
                memcpy(sz, tmp_states, sizeof(double) * VSW_NX);
                double t1 = b->kept_lengths[i * keep + a];
                b->kept_lengths[i * keep + a] = b->kept_lengths[i * keep + z];
                b->kept_lengths[i * keep + z] = t1;
                t1 = b->kept_durations[i * keep + a];
                b->kept_durations[i * keep + a] = b->kept_durations[i * keep + z];
                b->kept_durations[i * keep + z] = t1;
            }
        }
    }
    b->outcome[i] = result;
    b->aux[i] = extra;
    b->steps[i] = walked;
    memcpy(b->final + i * VSW_NX, ln->x, sizeof(double) * VSW_NX);
    ln->walk = -1;
}

/* A step of the lane's walk begins at its section state (unless the walk is over). */
static int vsw_lane_step_start(vsw_batch *b, vsw_lane *ln)
{
    if (ln->walked >= b->max_steps || vsw_stop_requested) {
        vsw_lane_walk_end(b, ln, VSW_WALKED, 0);
        return VSW_PHASE_STALLED;
    }
    if (b->max_period > 0)
        memcpy(ln->history[ln->walked % b->max_period], ln->x, sizeof(double) * VSW_NX);
    if (b->step_stride > 0)
        vsw_constants(b->params + ln->walk * b->params_stride + ln->walked * b->step_stride,
                      ln->constants);
    ln->phase = VSW_START_PHASE;
    ln->visit = 0;
    ln->duration = 0.0;
    ln->length = NAN;
    memcpy(ln->y, ln->x, sizeof(double) * VSW_NX);
    return vsw_lane_phase_start(&b->tol, ln);
}

/* The lane's step completed at ln->y: the walk's checks (converged, periodic). */
static int vsw_lane_step_walked(vsw_batch *b, vsw_lane *ln)
{
    const long long i = ln->walk, keep = b->keep;
    memcpy(ln->x, ln->y, sizeof(double) * VSW_NX);
    const long long walked = ++ln->walked;
    if (keep > 0) { /* a ring of the last `keep` steps, unrolled at the walk's end */
        long long r = (walked - 1) % keep;
        memcpy(b->kept_states + (i * keep + r) * VSW_NX, ln->x, sizeof(double) * VSW_NX);
        b->kept_lengths[i * keep + r] = ln->length;
        b->kept_durations[i * keep + r] = ln->duration;
    }
    if (b->target && b->conv_tol > 0.0
        && vsw_distance(ln->x, b->target) <= b->conv_tol * ln->target_scale) {
        vsw_lane_walk_end(b, ln, VSW_CONVERGED, 0);
        return VSW_PHASE_STALLED;
    }
    if (b->period_tol > 0.0 && b->max_period > 0) {
        const double bound = b->period_tol * vsw_scale(ln->x);
        for (long long k = b->target ? 2 : 1; k <= b->max_period && k <= walked; ++k) {
            if (vsw_distance(ln->x, ln->history[(walked - k) % b->max_period]) > bound) continue;
            /* a cycle's points are apart: near a fixed point every lag is small */
            int apart = 1;
            for (long long j = 1; j < k; ++j)
                if (vsw_distance(ln->x, ln->history[(walked - j) % b->max_period])
                    <= VSW_APART * bound)
                    apart = 0;
            if (apart) {
                vsw_lane_walk_end(b, ln, VSW_PERIODIC, (int)k);
                return VSW_PHASE_STALLED;
            }
            break;
        }
    }
    return vsw_lane_step_start(b, ln);
}

/* The lane's phase ended with `code` (a watched index, or stalled): the event's reset and
   the next phase, or the step's end. Returns the next phase's code (the walk may have
   ended: ln->walk < 0). */
static int vsw_lane_phase_end(vsw_batch *b, vsw_lane *ln, int code)
{
    ln->duration += ln->time;
    if (b->visit_durations && ln->walk == 0 && ln->walked == 0) {
        b->visit_durations[ln->visit] = ln->time;
        *b->visits = ln->visit + 1;
    }
    if (code < 0) { /* the section state is kept as it was */
        vsw_lane_walk_end(b, ln, VSW_STALLED, 0);
        return VSW_PHASE_STALLED;
    }
    const int what = vsw_watch_what[ln->phase][code];
    if (what < 0) {
        vsw_lane_walk_end(b, ln, VSW_FELL, -1 - what);
        return VSW_PHASE_STALLED;
    }
    if (vsw_event_ends_step[what]) vsw_step_length(ln->constants, ln->y, &ln->length);
    double y_new[VSW_NX];
    vsw_reset(what, ln->constants, ln->y, y_new);
    vsw_samples *s = ln->samples;
    if (s != NULL && s->event != NULL) {
        s->event[s->events] = what;
        s->event_time[s->events] = ln->duration;
        memcpy(s->before + s->events * VSW_NX, ln->y, sizeof(double) * VSW_NX);
        memcpy(s->after + s->events * VSW_NX, y_new, sizeof(double) * VSW_NX);
        ++s->events;
    }
    memcpy(ln->y, y_new, sizeof(double) * VSW_NX);
    if (!vsw_finite(ln->y)) {
        vsw_lane_walk_end(b, ln, VSW_STALLED, 0);
        return VSW_PHASE_STALLED;
    }
    if (vsw_event_ends_step[what]) return vsw_lane_step_walked(b, ln);
    ln->phase = vsw_event_target[what];
    if (++ln->visit > VSW_NPHASES) {
        vsw_lane_walk_end(b, ln, VSW_STALLED, 0);
        return VSW_PHASE_STALLED;
    }
    return vsw_lane_phase_start(&b->tol, ln);
}

/* The lane's next walk, until one needs an RK step (walks that end at once are written
   on the way); the lane is empty when the batch has none left. */
static int vsw_lane_load(vsw_batch *b, vsw_lane *ln)
{
    while (b->next < b->n) {
        const long long i = b->next++;
        ln->walk = i;
        ln->walked = 0;
        ln->samples = i == 0 ? b->samples : NULL;
        /* The model's functions take its constants, computed here from the parameters
           once a walk (the table's vsw_constants). */
        vsw_constants(b->params + i * b->params_stride, ln->constants);
        memcpy(ln->x, b->states + i * VSW_NX, sizeof(double) * VSW_NX);
        for (long long r = 0; r < b->keep; ++r) {
            for (int j = 0; j < VSW_NX; ++j) b->kept_states[(i * b->keep + r) * VSW_NX + j] = NAN;
            b->kept_lengths[i * b->keep + r] = NAN;
            b->kept_durations[i * b->keep + r] = NAN;
        }
        ln->target_scale = b->target ? vsw_scale(b->target) : 1.0;
        if (!vsw_finite(ln->x)) {
            vsw_lane_walk_end(b, ln, VSW_STALLED, 0);
            continue;
        }
        int code = vsw_lane_step_start(b, ln);
        while (ln->walk >= 0 && code != VSW_READY) code = vsw_lane_phase_end(b, ln, code);
        if (ln->walk >= 0) return VSW_READY;
    }
    ln->walk = -1;
    return VSW_PHASE_STALLED;
}

/* Walks held at once: with several phases, twice the lanes, so that each RK step can take
   its lanes from walks in one phase (the phase most of them are in): a lane in another
   phase than its neighbours would cost that phase's flow on every lane. One phase: the
   lanes themselves. */
#define VSW_SLOTS (VSW_NPHASES > 1 ? 2 * VSW_LANES : VSW_LANES)

/* One field of the lanes' walks as one vector */
#if VSW_LANES == 4
#define vsw_lanes_gather(from, field) \
    ((vsw_lanes){from[0]->field, from[1]->field, from[2]->field, from[3]->field})
#else
#define vsw_lanes_gather(from, field)                                                      \
    __extension__({                                                                        \
        vsw_lanes gathered_;                                                               \
        for (int l_ = 0; l_ < VSW_LANES; ++l_) gathered_[l_] = from[l_]->field;            \
        gathered_;                                                                         \
    })
#endif

/* The walks of the batch, VSW_LANES at a time in lockstep: every lane holding a walk takes
   one RK step of its own size in its own phase with the others (one vector operation per
   scalar one), then each lane alone checks the step, locates events on its dense output
   and goes on to its next phase, step or walk. A lane's walk is the scalar integrator's,
   whichever lane it runs in and whatever the others do. */
static void vsw_batch_run(vsw_batch *b)
{
    vsw_lane slots[VSW_SLOTS];
    for (int k = 0; k < VSW_SLOTS; ++k) {
        slots[k].walk = -1;
        vsw_lane_load(b, &slots[k]);
    }
    vsw_lanes c[VSW_NC > 0 ? VSW_NC : 1], y[VSW_NX], f0[VSW_NX], y_new[VSW_NX], h, err;
    vsw_lanes K[VSW_RK_ALL][VSW_NX], g1[VSW_MAX_WATCH];
    for (;;) {
        /* the phase most walks are in, and up to VSW_LANES of them, in slot order */
        int in_phase[VSW_NPHASES] = {0}, busiest = -1;
        for (int k = 0; k < VSW_SLOTS; ++k)
            if (slots[k].walk >= 0) ++in_phase[slots[k].phase];
        for (int ph = 0; ph < VSW_NPHASES; ++ph)
            if (in_phase[ph] > 0 && (busiest < 0 || in_phase[ph] > in_phase[busiest]))
                busiest = ph;
        if (busiest < 0) return;
        int slot_of[VSW_LANES], live = 0, taken = 0;
        for (int k = 0; k < VSW_SLOTS && taken < VSW_LANES; ++k)
            if (slots[k].walk >= 0 && slots[k].phase == busiest) slot_of[taken++] = k;
        live = (1 << taken) - 1;
        /* lanes without a walk compute a copy of the first, so that every value stays tame;
           the vectors built in registers (a lane stored into a vector in memory and the
           vector loaded back stalls the load) */
        const vsw_lane *from[VSW_LANES];
        for (int l = 0; l < VSW_LANES; ++l) from[l] = &slots[slot_of[l < taken ? l : 0]];
        h = vsw_lanes_gather(from, h);
        for (int i = 0; i < VSW_NX; ++i) {
            y[i] = vsw_lanes_gather(from, y[i]);
            f0[i] = vsw_lanes_gather(from, f0[i]);
        }
        for (int k = 0; k < VSW_NC; ++k) c[k] = vsw_lanes_gather(from, constants[k]);
        vsw_lanes_rk_step(busiest, live, c, y, f0, h, &b->tol, K, y_new, &err);
#ifdef VSW_COUNT_CALLS
        vsw_rk_calls[busiest] += taken;
#endif
        int accepted = 0; /* a rejected step's guards are not needed */
        for (int l = 0; l < taken; ++l) accepted |= (err[l] < 1.0) << l;
        if (accepted) vsw_lanes_watch_in(busiest, accepted, c, y_new, g1);
        for (int l = 0; l < taken; ++l) {
            vsw_lane *ln = &slots[slot_of[l]];
            double yl[VSW_NX], gl[VSW_MAX_WATCH];
            for (int i = 0; i < VSW_NX; ++i) yl[i] = y_new[i][l];
            for (int k = 0; k < VSW_MAX_WATCH; ++k) gl[k] = g1[k][l];
            int code = vsw_lane_stepped(&b->tol, ln, l, err[l], K, yl, gl);
            while (ln->walk >= 0 && code != VSW_READY) code = vsw_lane_phase_end(b, ln, code);
            if (ln->walk < 0) vsw_lane_load(b, ln);
        }
    }
}

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
   durations (rows of a trajectory that walked fewer steps are NaN). A walk that falls or
   stalls keeps the section state its last step started from. */
VSW_EXPORT void vsw_batch_simulate(long long n, const double *params, long long params_stride,
                        const double *states, const double *options, const double *target,
                        long long max_steps, long long max_period, long long keep, int *outcome,
                        int *aux, long long *steps, double *final, double *kept_states,
                        double *kept_lengths, double *kept_durations)
{
    vsw_batch b = {
        .n = n, .params_stride = params_stride, .max_steps = max_steps,
        .max_period = max_period > VSW_MAX_PERIOD ? VSW_MAX_PERIOD : max_period, .keep = keep,
        .next = 0, .params = params, .states = states, .target = target,
        .tol = {options[0], options[1], options[2], INFINITY}, .conv_tol = options[3],
        .period_tol = options[4], .outcome = outcome, .aux = aux, .steps = steps,
        .final = final, .kept_states = kept_states, .kept_lengths = kept_lengths,
        .kept_durations = kept_durations, .visit_durations = NULL, .visits = NULL,
        .step_stride = 0,
    };
    vsw_batch_run(&b);
}

/* Walks whose parameters change from step to step (a terrain drawn per step): step k of
   walk i (k < max_steps) takes the parameter row params[(i * max_steps + k) * VSW_NP ...],
   its constants computed at the step event that starts it. No convergence or period
   checks, nothing kept; the outputs and the rules are vsw_batch_simulate's, so that a
   walk of many steps here is the same as one call of one step per step, each from the
   state the last ended in. */
VSW_EXPORT void vsw_batch_walk_steps(long long n, const double *params, const double *states,
                                     const double *options, long long max_steps, int *outcome,
                                     int *aux, long long *steps, double *final)
{
    vsw_batch b = {
        .n = n, .params_stride = max_steps * VSW_NP, .step_stride = VSW_NP,
        .max_steps = max_steps, .max_period = 0, .keep = 0, .next = 0, .params = params,
        .states = states, .target = NULL, .tol = {options[0], options[1], options[2], INFINITY},
        .conv_tol = 0.0, .period_tol = 0.0, .outcome = outcome, .aux = aux, .steps = steps,
        .final = final, .kept_states = NULL, .kept_lengths = NULL, .kept_durations = NULL,
        .visit_durations = NULL, .visits = NULL,
    };
    vsw_batch_run(&b);
}

/* One walk of one step from `state` (vsw_batch_step_phases, vsw_batch_sample_step). */
static int vsw_one_step(const double *params, double *state, vsw_tolerances tol,
                        double *durations, int *visits, int *failure, double *length,
                        vsw_samples *samples)
{
    int outcome = VSW_STALLED, aux = 0;
    long long steps = 0;
    double final[VSW_NX], kept_state[VSW_NX], kept_duration;
    *visits = 0;
    vsw_batch b = {
        .n = 1, .params_stride = 0, .max_steps = 1, .max_period = 0, .keep = 1, .next = 0,
        .params = params, .states = state, .target = NULL, .tol = tol, .conv_tol = 0.0,
        .period_tol = 0.0, .outcome = &outcome, .aux = &aux, .steps = &steps, .final = final,
        .kept_states = kept_state, .kept_lengths = length, .kept_durations = &kept_duration,
        .visit_durations = durations, .visits = visits, .step_stride = 0, .samples = samples,
    };
    vsw_batch_run(&b);
    *failure = outcome == VSW_FELL ? aux : 0;
    if (outcome != VSW_WALKED) return outcome;
    if (steps != 1) return VSW_STALLED; /* a stop before the step */
    memcpy(state, final, sizeof(double) * VSW_NX);
    return VSW_WALKED;
}

/* One step from the section state `state` with parameters `params`, each phase visit's
   duration recorded (the periodic-orbit solver's guess of the phase durations and its
   confirmation, without the SciPy route): returns VSW_WALKED (`state` replaced by the next
   section state), VSW_FELL (*failure its index) or VSW_STALLED; durations[k] the k-th phase
   visit's duration (room for VSW_NPHASES + 1), *visits their number, *length the step's
   length (NaN unless the step completed, and for a model without one). options: rtol,
   atol, phase time limit, as vsw_batch_simulate's. The batch's walk of one step, so the
   same numbers. */
VSW_EXPORT int vsw_batch_step_phases(const double *params, double *state, const double *options,
                                     double *durations, int *visits, int *failure,
                                     double *length)
{
    const vsw_tolerances tol = {options[0], options[1], options[2], INFINITY};
    return vsw_one_step(params, state, tol, durations, visits, failure, length, NULL);
}

/* vsw_batch_step_phases with the step's states sampled as SciPy's route samples them
   (HybridModel.simulate: see vsw_samples), the RK steps at most options[3] long: sample k
   at time t[k] from the step's start, state x[k * VSW_NX ...], in phase phase[k]; room for
   `capacity`, *count the samples the step took (more than `capacity`: only the first
   written). With `event` not NULL, each event of the step (HybridModel.step_events): its
   index event[k], time event_time[k], the states before[k * VSW_NX ...] and after its
   reset after[k * VSW_NX ...] (room for VSW_NPHASES + 1), *events their number. Returns
   what vsw_batch_step_phases returns. */
VSW_EXPORT int vsw_batch_sample_step(const double *params, double *state, const double *options,
                                     long long capacity, double *t, double *x, int *phase,
                                     long long *count, int *failure, int *event,
                                     double *event_time, double *before, double *after,
                                     int *events)
{
    const vsw_tolerances tol = {options[0], options[1], options[2], options[3]};
    vsw_samples samples = {
        .t = t, .x = x, .phase = phase, .capacity = capacity, .count = 0, .event = event,
        .event_time = event_time, .before = before, .after = after, .events = 0,
    };
    double durations[VSW_NPHASES + 1], length;
    int visits;
    const int code =
        vsw_one_step(params, state, tol, durations, &visits, failure, &length, &samples);
    *count = samples.count;
    if (events != NULL) *events = samples.events;
    return code;
}

/* Phase `phase`'s flow and guards at n states (parameters `params`) by the scalar functions
   into scalar_out and by the lanes' twins into lanes_out (per state VSW_NX flow components,
   then VSW_MAX_WATCH guards; n a multiple of VSW_LANES), the lanes in `live` only (the
   others' rows left as they were): tests/test_batch.py compares them bit for bit. */
VSW_EXPORT void vsw_batch_lanes_check(int phase, const double *params, const double *states,
                                      long long n, int live, double *scalar_out,
                                      double *lanes_out)
{
    const int row = VSW_NX + VSW_MAX_WATCH;
    double c[VSW_NC > 0 ? VSW_NC : 1];
    vsw_lanes cl[VSW_NC > 0 ? VSW_NC : 1], x[VSW_NX], f[VSW_NX], g[VSW_MAX_WATCH];
    vsw_constants(params, c);
    for (int k = 0; k < VSW_NC; ++k) cl[k] = vsw_lanes_splat(c[k]);
    for (long long i = 0; i < n; ++i) {
        vsw_flow(phase, c, states + i * VSW_NX, scalar_out + i * row);
        vsw_watch(phase, c, states + i * VSW_NX, scalar_out + i * row + VSW_NX);
    }
    for (long long i = 0; i + VSW_LANES <= n; i += VSW_LANES) {
        for (int k = 0; k < VSW_NX; ++k)
            for (int l = 0; l < VSW_LANES; ++l) x[k][l] = states[(i + l) * VSW_NX + k];
        vsw_lanes_flow(phase, live, cl, x, f);
        vsw_lanes_watch(phase, live, cl, x, g);
        for (int l = 0; l < VSW_LANES; ++l) {
            if (!((live >> l) & 1)) continue;
            for (int k = 0; k < VSW_NX; ++k) lanes_out[(i + l) * row + k] = f[k][l];
            for (int k = 0; k < vsw_n_watch[phase]; ++k)
                lanes_out[(i + l) * row + VSW_NX + k] = g[k][l];
        }
    }
}

/* 1 where the build takes its sines and cosines from libmvec (vsw/dynamics/csrc/lanes.h), else 0. */
VSW_EXPORT int vsw_batch_vector_sines(void)
{
    return VSW_MVEC;
}

/* The model's sizes, for the caller's check against its descriptor. */
VSW_EXPORT void vsw_batch_sizes(long long *out)
{
    out[0] = VSW_NP;
    out[1] = VSW_NX;
    out[2] = VSW_NPHASES;
    out[3] = VSW_NEVENTS;
}
