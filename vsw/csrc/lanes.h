/* Lanes of walks: VSW_LANES walks advanced in lockstep by one vector operation each
 * (vsw/csrc/hybrid_batch.c; the model tables' *_lanes functions, written by
 * derive/sim_codegen.py). Each lane's arithmetic is the scalar code's, operation for
 * operation: IEEE addition, multiplication, division and square root round the same in a
 * vector register, the build contracts nothing into FMAs, and sin and cos are libm's,
 * called on each lane. So a walk's result does not depend on its lane, its neighbours or
 * the lane count: byte-identical to the scalar functions'.
 */
#ifndef VSW_LANES_H
#define VSW_LANES_H

#include <math.h>

#ifndef VSW_LANES
#define VSW_LANES 4
#endif

typedef double vsw_lanes __attribute__((vector_size(VSW_LANES * sizeof(double))));
typedef long long vsw_lane_mask __attribute__((vector_size(VSW_LANES * sizeof(long long))));

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

/* Sines and cosines on the lanes in `live` only (a bit each; 0 on the others): libm's
   calls are most of a flow's cost, and a lane without a walk, or in another phase, needs
   none. */
static inline vsw_lanes vsw_lanes_sin(vsw_lanes x, int live)
{
    vsw_lanes r = {0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) r[l] = sin(x[l]);
    return r;
}

static inline vsw_lanes vsw_lanes_cos(vsw_lanes x, int live)
{
    vsw_lanes r = {0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) r[l] = cos(x[l]);
    return r;
}

/* sin and cos of each lane from one call: GCC fuses them into glibc's sincos, whose
   values are sin's and cos's bit for bit */
static inline void vsw_lanes_sincos(vsw_lanes x, int live, vsw_lanes *s, vsw_lanes *c)
{
    *s = *c = (vsw_lanes){0.0};
    for (int l = 0; l < VSW_LANES; ++l)
        if ((live >> l) & 1) {
            (*s)[l] = sin(x[l]);
            (*c)[l] = cos(x[l]);
        }
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
