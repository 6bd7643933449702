/* Lanes of walks: VSW_LANES walks advanced in lockstep by one vector operation each
 * (vsw/dynamics/csrc/hybrid_batch.c; the model tables' *_lanes functions, written by
 * derive/sim_codegen.py). Each lane's arithmetic is the scalar code's, operation for
 * operation: IEEE addition, multiplication, division and square root round the same in a
 * vector register, the build contracts nothing into FMAs, and sines and cosines come from
 * one function whichever the lane count (vsw_sin and vsw_cos below: the scalar code calls
 * them too). So a walk's result does not depend on its lane, its neighbours or the lane
 * count: byte-identical to the scalar functions'.
 *
 * Sines and cosines: with AVX2 on glibc, glibc's vector math library (libmvec's
 * _ZGVdN4v_sin and _ZGVdN4v_cos, a few ulp from the exact values), four values for about
 * the price of one libm call (every model's step in about half the time: benchmark case
 * 15, against the same code with libm's), whatever the lane count (four at a time); a
 * scalar value is taken as lane 0 of four copies, so that it gets the very value a lane
 * would (a scalar sine and cosine pair: two four-wide calls). Elsewhere, or built with
 * -DVSW_NO_MVEC, libm's sin and cos, lane by lane: values a few ulp from libmvec's, so
 * walks that differ from the AVX2 build's by about the integrator's rounding.
 */
#ifndef VSW_LANES_H
#define VSW_LANES_H

#include <math.h>

#ifndef VSW_LANES
#define VSW_LANES 4
#endif

typedef double vsw_lanes __attribute__((vector_size(VSW_LANES * sizeof(double))));
typedef long long vsw_lane_mask __attribute__((vector_size(VSW_LANES * sizeof(long long))));

#if defined(__AVX2__) && defined(__GLIBC__) && !defined(VSW_NO_MVEC)
#define VSW_MVEC 1
/* glibc's AVX2 variants (the vector ABI's names; libmvec, linked with -lmvec): four values
   at once, each from its own value alone, whatever the others hold */
typedef double vsw_quad __attribute__((vector_size(4 * sizeof(double))));
vsw_quad _ZGVdN4v_sin(vsw_quad);
vsw_quad _ZGVdN4v_cos(vsw_quad);

/* fn on every lane, four at a time (whatever the lane count, each value gets what the
   scalar code would get: lane 0 of four) */
#define VSW_MVEC_LANES(fn, x)                                                              \
    __extension__({                                                                        \
        vsw_lanes r_;                                                                      \
        for (int l0_ = 0; l0_ < VSW_LANES; l0_ += 4) {                                     \
            vsw_quad q_;                                                                   \
            for (int k_ = 0; k_ < 4; ++k_)                                                 \
                q_[k_] = (x)[l0_ + k_ < VSW_LANES ? l0_ + k_ : l0_];                       \
            q_ = fn(q_);                                                                   \
            for (int k_ = 0; k_ < 4 && l0_ + k_ < VSW_LANES; ++k_) r_[l0_ + k_] = q_[k_];  \
        }                                                                                  \
        r_;                                                                                \
    })
#else
#define VSW_MVEC 0
#endif

static inline vsw_lanes vsw_lanes_splat(double v)
{
    vsw_lanes r;
    for (int l = 0; l < VSW_LANES; ++l) r[l] = v;
    return r;
}

static inline vsw_lanes vsw_lanes_sq(vsw_lanes x)
{
    return x * x;
}

/* The scalar code's sine and cosine (the tables' CasADi functions call these) */
static inline double vsw_sin(double x)
{
#if VSW_MVEC
    return _ZGVdN4v_sin((vsw_quad){x, x, x, x})[0];
#else
    return sin(x);
#endif
}

static inline double vsw_cos(double x)
{
#if VSW_MVEC
    return _ZGVdN4v_cos((vsw_quad){x, x, x, x})[0];
#else
    return cos(x);
#endif
}

/* Sines and cosines on the lanes in `live` (a bit each): lane by lane, only those (libm's
   calls are most of a flow's cost, and a lane without a walk, or in another phase, needs
   none; 0 on the others); with libmvec, every lane at once (the others' values mean
   nothing). */
static inline vsw_lanes vsw_lanes_sin(vsw_lanes x, int live)
{
#if VSW_MVEC
    (void)live;
    return VSW_MVEC_LANES(_ZGVdN4v_sin, x);
#else
    vsw_lanes r = {0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) r[l] = sin(x[l]);
    return r;
#endif
}

static inline vsw_lanes vsw_lanes_cos(vsw_lanes x, int live)
{
#if VSW_MVEC
    (void)live;
    return VSW_MVEC_LANES(_ZGVdN4v_cos, x);
#else
    vsw_lanes r = {0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) r[l] = cos(x[l]);
    return r;
#endif
}

/* sin and cos of each lane: with libmvec two four-wide calls; else lane by lane, where GCC
   fuses the two calls into glibc's sincos, whose values are sin's and cos's bit for bit */
static inline void vsw_lanes_sincos(vsw_lanes x, int live, vsw_lanes *s, vsw_lanes *c)
{
#if VSW_MVEC
    *s = vsw_lanes_sin(x, live);
    *c = vsw_lanes_cos(x, live);
#else
    *s = *c = (vsw_lanes){0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) {
            (*s)[l] = sin(x[l]);
            (*c)[l] = cos(x[l]);
        }
#endif
}

static inline vsw_lanes vsw_lanes_sqrt(vsw_lanes x)
{
    vsw_lanes r;
    for (int l = 0; l < VSW_LANES; ++l) r[l] = sqrt(x[l]);
    return r;
}

static inline vsw_lanes vsw_lanes_fabs(vsw_lanes x)
{
    vsw_lanes r;
    for (int l = 0; l < VSW_LANES; ++l) r[l] = fabs(x[l]);
    return r;
}

/* a where the mask is set, b elsewhere */
static inline vsw_lanes vsw_lanes_select(vsw_lane_mask mask, vsw_lanes a, vsw_lanes b)
{
    return (vsw_lanes)(((vsw_lane_mask)a & mask) | ((vsw_lane_mask)b & ~mask));
}

/* hybrid_batch.c's vsw_fmax on each lane: a NaN argument is ignored */
static inline vsw_lanes vsw_lanes_fmax(vsw_lanes a, vsw_lanes b)
{
    return vsw_lanes_select((a >= b) | (b != b), a, b);
}

#endif
