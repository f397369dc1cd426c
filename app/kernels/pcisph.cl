// PCISPH (Solenthaler and Pajarola 2009) with Akinci et al. (2012) wall particles.
// NumPy twins: app/core/sph.py and app/core/sph_grid.py (see there for the maths).
//
// Determinism: the only atomics are integer increments that count (order-free) and
// slot particles into cells, after which each cell is sorted by the previous index;
// an atomic max of non-negative floats (exact in any order). Every sum gathers over a
// particle's own neighbour list in a fixed order (eight lanes, then a fixed reduction
// tree), so the output is bit-reproducible.
//
// Speed on PoCL's CPU device (see docs/sph.md): the pair loops run eight neighbours at a
// time in float8. PoCL (LLVM 14) calls its built-in functions out of line, spilling every
// live vector register around each call (the reason fma()/mad() are ~8x slower than
// a*b+c), so hot loops use operators, ?: for select/min/max, pointer casts for vector
// loads and clang's sqrt builtins; built-ins remain only once per particle.

// grid origin (xyz), cells per axis, 1 / cell size, kernel support h, 8 / (pi h^3), mass
#define GRID_ARGS float4 origin, int4 dims, float inv_cell, float h, float sigma, float mass
// a particle's fluid neighbours (max_nb a row) and wall neighbours (max_wall_nb a row), and
// the wall particles' positions and volumes psi
#define NEIGHBOUR_ARGS                                                                      \
    __global const int *nb, __global const int *nb_count, int max_nb,                       \
        __global const float4 *walls, __global const float *psi, __global const int *wall_nb, \
        __global const int *wall_nb_count, int max_wall_nb

// correctly rounded square roots, inlined (PoCL's sqrt() is the same instruction behind a
// call); other compilers get the built-in
#if defined(__clang__) && defined(__AVX__)
#define SQRT8(x) __builtin_ia32_sqrtps256(x)
#else
#define SQRT8(x) sqrt(x)
#endif
#ifdef __clang__
#define SQRT1(x) __builtin_sqrtf(x)
#else
#define SQRT1(x) sqrt(x)
#endif

// four consecutive float4 rows (aligned as a float4 is)
typedef float16 float16_rows __attribute__((aligned(16)));

// Neighbour lists are appended eight candidates at a time. With AVX2 the hits are moved
// to the front of one vector by a permutation looked up by their lane mask, then stored
// whole; elsewhere (or with -DPORTABLE_COMPACTION) each lane is stored at its prefix-sum
// slot. A GPU's build (-DLANE_BUILD, app/kernels/launch_shapes.py) walks the candidates
// one at a time instead: its lanes are the work-items, and eight candidates a work-item
// only multiply each lane's registers. The same lists every way (held together by tests).
#if defined(__clang__) && defined(__AVX2__) && !defined(PORTABLE_COMPACTION) && \
    !defined(LANE_BUILD)
#define AVX2_COMPACTION
typedef int8 int8_slots __attribute__((aligned(4)));
#endif

#define ZERO8 ((float8)(0.0f))
#define LANES ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
// eight consecutive elements at p (32-byte aligned: list rows and k are multiples of 8)
#define LOAD8(type, p) (*(__global const type *)(p))
#define STORE8(p, v) (*(__global float8 *)(p) = (v))

// a work-item's clip, the clips in its launch and its particle's row, in a launch on
// (n_clip, batch) work-items (see count_cells)
#define CLIP ((int)get_global_id(1))
#define BATCH ((int)get_global_size(1))
#define PARTICLE (CLIP * (int)get_global_size(0) + (int)get_global_id(0))

inline float dot3(float3 a, float3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// Cubic spline: both branches are evaluated and selected (the q <= 0.5 test is
// data-dependent; a mispredicted branch per pair cost more than the arithmetic).
inline float kernel_w(float r, float h, float sigma) {
    float q = r / h;
    float t = q < 1.0f ? 1.0f - q : 0.0f;
    float inner = sigma * (6.0f * (q * q * q - q * q) + 1.0f);
    float outer = sigma * 2.0f * t * t * t;
    return q <= 0.5f ? inner : outer;
}

// grad W = d * kernel_grad_scale(r): zero at r = 0 and beyond h
inline float kernel_grad_scale(float r, float h, float sigma) {
    float q = r / h;
    float f = q <= 0.5f ? q * (3.0f * q - 2.0f) : -(1.0f - q) * (1.0f - q);
    float g = 6.0f * sigma * f / (h * r);
    return (r <= 1e-9f * h || q >= 1.0f) ? 0.0f : g;
}

// cubic spline shape w(q) = W / sigma of eight pairs (see kernel_w)
inline float8 kernel_w8(float8 q) {
    float8 t = q < 1.0f ? 1.0f - q : ZERO8;
    float8 inner = 6.0f * (q * q * q - q * q) + 1.0f;
    float8 outer = 2.0f * t * t * t;
    return q <= 0.5f ? inner : outer;
}

// kernel_grad_scale of eight pairs
inline float8 kernel_grad_scale8(float8 r, float h, float sigma) {
    float8 q = r / h;
    float8 f = q <= 0.5f ? q * (3.0f * q - 2.0f) : -(1.0f - q) * (1.0f - q);
    float8 g = 6.0f * sigma * f / (h * r);
    return ((r <= 1e-9f * h) | (q >= 1.0f)) ? ZERO8 : g;
}

// fixed-order horizontal sum (deterministic)
inline float sum8(float8 v) {
    float4 a = v.lo + v.hi;
    float2 b = a.lo + a.hi;
    return b.x + b.y;
}

// The host enqueues pressure iterations ahead of reading their errors. Iteration m is a
// no-op for a clip (its work-items return at once) when m >= check_from and the clip's
// max compression of the previous iteration is below eta: exactly when its loop has
// stopped (a skipped iteration leaves its error 0, so the ones after it skip too). The
// errors of iteration m are err[m * BATCH + CLIP], one per clip of the batch.
inline int loop_stopped(__global volatile const uint *err, int iteration, int check_from,
                        float eta) {
    return iteration >= check_from && as_float(err[(iteration - 1) * BATCH + CLIP]) < eta;
}

inline int imin(int a, int b) {
    return a < b ? a : b;
}

inline int imax(int a, int b) {
    return a > b ? a : b;
}

// Truncation instead of floor: the two differ only below zero, where the clamp gives 0
// either way (the same cells as app/core/sph_grid.py's cell_indices).
inline int3 cell_of(float4 x, float4 origin, float inv_cell, int4 dims) {
    float3 f = (x.xyz - origin.xyz) * inv_cell;
    return (int3)(imin(imax((int)f.x, 0), dims.x - 1), imin(imax((int)f.y, 0), dims.y - 1),
                  imin(imax((int)f.z, 0), dims.z - 1));
}

inline int cell_index(int3 c, int4 dims) {
    return (c.z * dims.y + c.y) * dims.x + c.x;
}

// A batch of clips lies in one set of buffers, clip-major: clip c's particles are rows
// [c n_clip, (c + 1) n_clip) and its cells [c n_cells, (c + 1) n_cells), so each clip
// sorts, finds neighbours and sums exactly as it does alone (docs/sph.md, "Clips in
// batches"). The kernels that need to know a particle's clip are launched on
// (n_clip, batch) work-items: the clip is the second index, the same in a work-group.
__kernel void count_cells(__global const float4 *pos, __global int *cell,
                          __global volatile int *counts, float4 origin, float inv_cell,
                          int4 dims, int n_cells) {
    int i = PARTICLE;
    int c = CLIP * n_cells + cell_index(cell_of(pos[i], origin, inv_cell, dims), dims);
    cell[i] = c;
    atomic_inc(&counts[c]);
}

// exclusive prefix sum of the counts (then zeroed for the next sort); one work-item
// cells' exclusive prefix sums in blocks of `block` cells, from `first` (each block's own
// start): one work-item walks every cell (first = 0, block = n_cells) on a CPU, where a
// launch costs more than the walk; one work-item per block after block_totals and
// scan_block_totals on a GPU, where one work-item walking 18k cells takes milliseconds
__kernel void scan_cells(__global int *counts, __global int *start, __global int *cursor,
                         __global const int *first, int n_cells, int block) {
    int b = get_global_id(0);
    int c0 = b * block;
    int c1 = min(c0 + block, n_cells);
    int s = first[b];
    for (int c = c0; c < c1; ++c) {
        start[c] = s;
        cursor[c] = s;
        s += counts[c];
        counts[c] = 0;
    }
    if (c1 == n_cells) start[n_cells] = s;
}

// each block's count of particles (a GPU's scan: block_totals, scan_block_totals, scan_cells)
__kernel void block_totals(__global const int *counts, __global int *totals, int n_cells,
                           int block) {
    int b = get_global_id(0);
    int c1 = min((b + 1) * block, n_cells);
    int s = 0;
    for (int c = b * block; c < c1; ++c) s += counts[c];
    totals[b] = s;
}

// exclusive prefix sums of the blocks' totals, in place: a block's first slot
__kernel void scan_block_totals(__global int *totals, int n_blocks) {
    int s = 0;
    for (int b = 0; b < n_blocks; ++b) {
        int t = totals[b];
        totals[b] = s;
        s += t;
    }
}

__kernel void scatter_cells(__global const int *cell, __global volatile int *cursor,
                            __global int *order) {
    int i = get_global_id(0);
    order[atomic_inc(&cursor[cell[i]])] = i;
}

// Each cell's slots sorted by previous index (an insertion sort: removes the atomics'
// order), then the cell's particles moved to their slots. One launch for both: a cell's
// sort and moves touch only its own slots.
__kernel void sort_reorder(__global const int *start, __global int *order,
                           __global const float4 *pos, __global const float4 *vel,
                           __global const float *p, __global const int *ids,
                           __global float4 *pos_out, __global float4 *vel_out,
                           __global float *p_out, __global int *ids_out) {
    int c = get_global_id(0);
    int b = start[c];
    int e = start[c + 1];
    for (int k = b + 1; k < e; ++k) {
        int v = order[k];
        int m = k - 1;
        while (m >= b && order[m] > v) {
            order[m + 1] = order[m];
            --m;
        }
        order[m + 1] = v;
    }
    for (int s = b; s < e; ++s) {
        int i = order[s];
        pos_out[s] = pos[i];
        vel_out[s] = vel[i];
        p_out[s] = p[i];
        ids_out[s] = ids[i];
    }
}

// frame[ids[s]] = x[s]: back to the caller's particle order
__kernel void unsort(__global const int *ids, __global const float4 *x, __global float4 *out) {
    int s = get_global_id(0);
    out[ids[s]] = x[s];
}

// Particles of `others` (sorted by cell, offsets `start`) closer than h to x_i, except
// `self` (-1: none), in stencil order: z, y rows of x-contiguous ranges of sorted rows.
// Candidates go eight at a time, read in blocks of eight (the last block may read
// up to seven rows past the range: the buffers have eight rows of slack), and are
// appended branch-free in candidate order (most candidates miss, unpredictably; misses
// may be written to the slots after the hits); in a GPU's build one at a time. Returns the count, which may exceed
// max_nb - 8 (an overflow: then only the first max_nb - 8 slots are hits).
inline int gather_neighbours(int self, float4 xi, __global const float4 *others,
                             __global const int *start, float4 origin, int4 dims,
                             float inv_cell, float h, __global const int8 *compact,
                             __global int *out, int max_nb) {
    int3 c = cell_of(xi, origin, inv_cell, dims);
    float h2 = h * h;
    int x0 = imax(c.x - 1, 0);
    int x1 = imin(c.x + 1, dims.x - 1);
    int z1 = imin(c.z + 1, dims.z - 1);
    int y1 = imin(c.y + 1, dims.y - 1);
    int n = 0;
    int last = max_nb - 8;  // the last slot a whole block of eight fits from
    for (int z = imax(c.z - 1, 0); z <= z1; ++z) {
        for (int y = imax(c.y - 1, 0); y <= y1; ++y) {
            int row = (z * dims.y + y) * dims.x;
            int end = start[row + x1 + 1];
#ifdef LANE_BUILD
            for (int j = start[row + x0]; j < end; ++j) {
                float4 xj = others[j];
                float dx = xi.x - xj.x;
                float dy = xi.y - xj.y;
                float dz = xi.z - xj.z;
                if (dx * dx + dy * dy + dz * dz < h2 && j != self) {
                    out[n < last ? n : last] = j;
                    ++n;
                }
            }
#else
            for (int j = start[row + x0]; j < end; j += 8) {
                float16 a = *(__global const float16_rows *)(others + j);
                float16 b = *(__global const float16_rows *)(others + j + 4);
                float8 dx = xi.x - (float8)(a.s048c, b.s048c);
                float8 dy = xi.y - (float8)(a.s159d, b.s159d);
                float8 dz = xi.z - (float8)(a.s26ae, b.s26ae);
                int8 jj = j + LANES;
                // -1 where a neighbour, 0 elsewhere
                int8 hit = (dx * dx + dy * dy + dz * dz < h2) & (jj < end) & (jj != self);
#ifdef AVX2_COMPACTION
                int mask = __builtin_ia32_movmskps256(as_float8(hit));
                int8 front = __builtin_ia32_permvarsi256(jj, compact[mask]);
                *(__global int8_slots *)(out + (n < last ? n : last)) = front;
                n += __builtin_popcount(mask);
#else
                // slot = n + hits in the lanes before; misses go to the first slot after
                // this block's hits (overwritten later)
                int8 one = -hit;
                int8 incl = one + (int8)(0, one.s012, one.s3456);
                incl += (int8)(0, 0, incl.s0123, incl.s45);
                incl += (int8)(0, 0, 0, 0, incl.s0123);
                int count = incl.s7;
                int8 slot = n + (hit != 0 ? incl - one : (int8)(count));
                slot = slot < last + 7 ? slot : (int8)(last + 7);
                out[slot.s0] = jj.s0;
                out[slot.s1] = jj.s1;
                out[slot.s2] = jj.s2;
                out[slot.s3] = jj.s3;
                out[slot.s4] = jj.s4;
                out[slot.s5] = jj.s5;
                out[slot.s6] = jj.s6;
                out[slot.s7] = jj.s7;
                n += count;
#endif
            }
#endif
        }
    }
    return n;
}

__kernel void find_neighbours(__global const float4 *pos, __global const int *start,
                              __global const float4 *walls, __global const int *wall_start,
                              GRID_ARGS, __global const int8 *compact, int max_nb,
                              int max_wall_nb, __global int *nb, __global int *nb_count,
                              __global int *wall_nb, __global int *wall_nb_count,
                              __global volatile int *overflow, int n_cells) {
    int i = PARTICLE;
    float4 xi = pos[i];
    __global int *list = nb + i * max_nb;
    int n = gather_neighbours(i, xi, pos, start + CLIP * n_cells, origin, dims, inv_cell, h,
                              compact, list, max_nb);
    int nw = gather_neighbours(-1, xi, walls, wall_start, origin, dims, inv_cell, h, compact,
                               wall_nb + i * max_wall_nb, max_wall_nb);
    // a list holds max_nb - 8 neighbours (the rest is room for whole blocks of eight);
    // more is an overflow, reported to the host, and the list is cut
    if (n > max_nb - 8 || nw > max_wall_nb - 8) {
        atomic_max(overflow, imax(n, nw));
    }
    n = imin(n, max_nb - 8);
    nw = imin(nw, max_wall_nb - 8);
    // pad to whole groups of eight with i itself (the pair loops read eight slots at a
    // time and mask the padding out)
    for (int k = n; k < ((n + 7) & ~7); ++k) {
        list[k] = i;
    }
    nb_count[i] = n;
    wall_nb_count[i] = nw;
}

// The viscosity of particle i at x(t): the SPH Laplacian over its fluid pairs into *lap
// and over its wall neighbours (at rest, weighted by psi as a mass: friction) into
// *wall_lap. Where `scale` is not null it also keeps what the pressure loop needs of
// x(t), which stays fixed through the loop: per fluid pair slot the scale s of
// grad W_ij = (x_i - x_j) s (zero in the padding up to a multiple of eight) and the wall
// sum sum_b psi_b grad W_ib into *wall_sum, so that pressure_predict evaluates no kernel
// gradient (storing the whole gradient instead streamed three times the bytes per pass
// and was slower).
inline void viscosity_sums(int i, __global const float4 *pos, __global const float4 *vel,
                           NEIGHBOUR_ARGS, float h, float sigma, __global float *scale,
                           float3 *lap, float3 *wall_lap, float3 *wall_sum) {
    float3 xi = pos[i].xyz;
    float3 vi = vel[i].xyz;
    float eps = 0.01f * h * h;
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    float8 lx = ZERO8;
    float8 ly = ZERO8;
    float8 lz = ZERO8;
    for (int k = 0; k < n; k += 8) {
        int8 j = LOAD8(int8, list + k);
        float4 x0 = pos[j.s0], x1 = pos[j.s1], x2 = pos[j.s2], x3 = pos[j.s3];
        float4 x4 = pos[j.s4], x5 = pos[j.s5], x6 = pos[j.s6], x7 = pos[j.s7];
        float4 v0 = vel[j.s0], v1 = vel[j.s1], v2 = vel[j.s2], v3 = vel[j.s3];
        float4 v4 = vel[j.s4], v5 = vel[j.s5], v6 = vel[j.s6], v7 = vel[j.s7];
        float8 dx = xi.x - (float8)(x0.x, x1.x, x2.x, x3.x, x4.x, x5.x, x6.x, x7.x);
        float8 dy = xi.y - (float8)(x0.y, x1.y, x2.y, x3.y, x4.y, x5.y, x6.y, x7.y);
        float8 dz = xi.z - (float8)(x0.z, x1.z, x2.z, x3.z, x4.z, x5.z, x6.z, x7.z);
        float8 ux = vi.x - (float8)(v0.x, v1.x, v2.x, v3.x, v4.x, v5.x, v6.x, v7.x);
        float8 uy = vi.y - (float8)(v0.y, v1.y, v2.y, v3.y, v4.y, v5.y, v6.y, v7.y);
        float8 uz = vi.z - (float8)(v0.z, v1.z, v2.z, v3.z, v4.z, v5.z, v6.z, v7.z);
        float8 r2 = dx * dx + dy * dy + dz * dz;
        // zero in the padding lanes, which is also what the pressure loop reads there
        float8 s = LANES < n - k ? kernel_grad_scale8(SQRT8(r2), h, sigma) : ZERO8;
        float8 grad_x = dx * s;
        float8 grad_y = dy * s;
        float8 grad_z = dz * s;
        float8 coef = (ux * dx + uy * dy + uz * dz) / (r2 + eps);
        lx = grad_x * coef + lx;
        ly = grad_y * coef + ly;
        lz = grad_z * coef + lz;
        if (scale) {
            STORE8(scale + k, s);
        }
    }
    *lap = (float3)(sum8(lx), sum8(ly), sum8(lz));
    float3 wl = (float3)(0.0f);
    float3 ws = (float3)(0.0f);
    int nw = wall_nb_count[i];
    __global const int *wlist = wall_nb + i * max_wall_nb;
    for (int k = 0; k < nw; ++k) {
        int b = wlist[k];
        float3 d = xi - walls[b].xyz;
        float r2 = dot3(d, d);
        float3 grad = d * (psi[b] * kernel_grad_scale(SQRT1(r2), h, sigma));
        wl += grad * (dot3(vi, d) / (r2 + eps));
        ws += grad;
    }
    *wall_lap = wl;
    *wall_sum = ws;
}

// a_np = g + visc lap + wall_visc wall_lap, and the pressure loop's x(t)-geometry (see
// viscosity_sums). With viscous substeps (docs/sph.md, "Viscosity in substeps") visc and
// wall_visc are the last substep's share.
__kernel void nonpressure_accel(__global const float4 *pos, __global const float4 *vel,
                                NEIGHBOUR_ARGS, GRID_ARGS,
                                __global const float4 *gravity, float visc, float wall_visc,
                                __global float4 *a_np, __global float *pair_scale,
                                __global float4 *wall_grad) {
    int i = PARTICLE;
    float4 g = gravity[CLIP];
    float3 lap, wall_lap, wall_sum;
    viscosity_sums(i, pos, vel, nb, nb_count, max_nb, walls, psi, wall_nb, wall_nb_count,
                   max_wall_nb, h, sigma, pair_scale + i * max_nb, &lap, &wall_lap,
                   &wall_sum);
    a_np[i] = (float4)(g.xyz + visc * lap + wall_visc * wall_lap, 0.0f);
    wall_grad[i] = (float4)(wall_sum, 0.0f);
}

// One explicit viscosity step at frozen positions: v_out = v + visc_dt lap +
// wall_visc_dt wall_lap, where visc_dt and wall_visc_dt carry the viscous substep's length.
__kernel void diffuse_velocity(__global const float4 *pos, __global const float4 *vel,
                               NEIGHBOUR_ARGS, GRID_ARGS, float visc_dt, float wall_visc_dt,
                               __global float4 *vel_out) {
    int i = get_global_id(0);
    float3 lap, wall_lap, wall_sum;
    viscosity_sums(i, pos, vel, nb, nb_count, max_nb, walls, psi, wall_nb, wall_nb_count,
                   max_wall_nb, h, sigma, 0, &lap, &wall_lap, &wall_sum);
    vel_out[i] = (float4)(vel[i].xyz + visc_dt * lap + wall_visc_dt * wall_lap, 0.0f);
}

// a_p from the pressures at x(t) (gradient scales stored by nonpressure_accel), then
// v* = (1 - damping)(v + dt (a_np + a_p)), x* = x + dt v*, clamped into [lo, hi]
// (stopping the velocity into the wall). Eight neighbours per step, summed per lane.
__kernel void pressure_predict(__global const float4 *pos, __global const float4 *vel,
                               __global const float *p, __global const float4 *a_np,
                               __global const int *nb, __global const int *nb_count,
                               int max_nb, __global const float *pair_scale,
                               __global const float4 *wall_grad, float mass,
                               float inv_rho0_sq, float dt, float damping, float4 lo,
                               float4 hi, __global float4 *pos_pred,
                               __global float4 *vel_pred, __global volatile const uint *err,
                               int iteration, int check_from, float eta) {
    if (loop_stopped(err, iteration, check_from, eta)) {
        return;
    }
    int i = PARTICLE;
    float3 xi = pos[i].xyz;
    float pi = p[i];
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    __global const float *scale = pair_scale + i * max_nb;
    float8 ax = ZERO8;
    float8 ay = ZERO8;
    float8 az = ZERO8;
    for (int k = 0; k < n; k += 8) {
        int8 j = LOAD8(int8, list + k);
        float4 x0 = pos[j.s0], x1 = pos[j.s1], x2 = pos[j.s2], x3 = pos[j.s3];
        float4 x4 = pos[j.s4], x5 = pos[j.s5], x6 = pos[j.s6], x7 = pos[j.s7];
        float8 pj = (float8)(p[j.s0], p[j.s1], p[j.s2], p[j.s3], p[j.s4], p[j.s5], p[j.s6],
                             p[j.s7]);
        float8 c = (pi + pj) * LOAD8(float8, scale + k);
        ax = (xi.x - (float8)(x0.x, x1.x, x2.x, x3.x, x4.x, x5.x, x6.x, x7.x)) * c + ax;
        ay = (xi.y - (float8)(x0.y, x1.y, x2.y, x3.y, x4.y, x5.y, x6.y, x7.y)) * c + ay;
        az = (xi.z - (float8)(x0.z, x1.z, x2.z, x3.z, x4.z, x5.z, x6.z, x7.z)) * c + az;
    }
    float3 acc = (float3)(sum8(ax), sum8(ay), sum8(az)) * -(mass * inv_rho0_sq);
    acc -= wall_grad[i].xyz * (pi * inv_rho0_sq);
    float3 v = (vel[i].xyz + dt * (a_np[i].xyz + acc)) * (1.0f - damping);
    float3 x = xi + dt * v;
    float3 zero = (float3)(0.0f);
    v = ((x < lo.xyz) & (v < zero)) ? zero : v;
    v = ((x > hi.xyz) & (v > zero)) ? zero : v;
    x = x < lo.xyz ? lo.xyz : x;
    x = x > hi.xyz ? hi.xyz : x;
    pos_pred[i] = (float4)(x, 0.0f);
    vel_pred[i] = (float4)(v, 0.0f);
}

// rho* at the predicted positions (fluid pairs eight at a time, padding masked out),
// p <- max(0, p + delta (rho* - rho0)), and the max relative compression of the clip into
// err[iteration * BATCH + CLIP] (atomic max of non-negative float bits).
__kernel void density_pressure(__global const float4 *pos_pred, NEIGHBOUR_ARGS, GRID_ARGS,
                               float rho0, float delta,
                               __global float *p, __global float *rho,
                               __global volatile uint *err, int iteration, int check_from,
                               float eta) {
    if (loop_stopped(err, iteration, check_from, eta)) {
        return;
    }
    int i = PARTICLE;
    float3 xi = pos_pred[i].xyz;
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    float8 acc = ZERO8;
    for (int k = 0; k < n; k += 8) {
        int8 j = LOAD8(int8, list + k);
        float4 p0 = pos_pred[j.s0], p1 = pos_pred[j.s1], p2 = pos_pred[j.s2];
        float4 p3 = pos_pred[j.s3], p4 = pos_pred[j.s4], p5 = pos_pred[j.s5];
        float4 p6 = pos_pred[j.s6], p7 = pos_pred[j.s7];
        float8 dx = xi.x - (float8)(p0.x, p1.x, p2.x, p3.x, p4.x, p5.x, p6.x, p7.x);
        float8 dy = xi.y - (float8)(p0.y, p1.y, p2.y, p3.y, p4.y, p5.y, p6.y, p7.y);
        float8 dz = xi.z - (float8)(p0.z, p1.z, p2.z, p3.z, p4.z, p5.z, p6.z, p7.z);
        float8 w = kernel_w8(SQRT8(dx * dx + dy * dy + dz * dz) / h);
        acc += LANES < n - k ? w : ZERO8;
    }
    // W(0) = sigma: the particle itself
    float sum = sigma * (1.0f + sum8(acc));
    float wall_sum = 0.0f;
    int nw = wall_nb_count[i];
    __global const int *wlist = wall_nb + i * max_wall_nb;
    for (int k = 0; k < nw; ++k) {
        int b = wlist[k];
        float3 d = xi - walls[b].xyz;
        wall_sum += psi[b] * kernel_w(SQRT1(dot3(d, d)), h, sigma);
    }
    float r = mass * sum + wall_sum;
    float e = r - rho0;
    float pn = p[i] + delta * e;
    float c = e / rho0;
    rho[i] = r;
    p[i] = pn > 0.0f ? pn : 0.0f;
    // the atomic only where it can raise the max (err starts at 0): one atomic per
    // particle on one cache line from both cores cost a third of this kernel
    __global volatile uint *e_clip = err + iteration * BATCH + CLIP;
    if (c > as_float(*e_clip)) {
        atomic_max(e_clip, as_uint(c));
    }
}
