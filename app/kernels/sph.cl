// PCISPH (Solenthaler and Pajarola 2009) with Akinci et al. (2012) wall particles.
// NumPy twins: app/core/sph.py and app/core/sph_grid.py (see there for the maths).
//
// Determinism: the only atomics are integer increments that count (order-free) and
// slot particles into cells, after which each cell is sorted by the previous index;
// an atomic max of non-negative floats (exact in any order). Every sum gathers over a
// particle's own neighbour list in a fixed order, so the output is bit-reproducible.
// Write a*b+c, never fma()/mad(): both are ~8x slower on PoCL's CPU device.

// grid origin (xyz), cells per axis, 1 / cell size, kernel support h, 8 / (pi h^3), mass
#define GRID_ARGS float4 origin, int4 dims, float inv_cell, float h, float sigma, float mass

inline float kernel_w(float r, float h, float sigma) {
    float q = r / h;
    if (q <= 0.5f) {
        return sigma * (6.0f * (q * q * q - q * q) + 1.0f);
    }
    float t = max(1.0f - q, 0.0f);
    return sigma * 2.0f * t * t * t;
}

// grad W = d * kernel_grad_scale(r): zero at r = 0 and beyond h
inline float kernel_grad_scale(float r, float h, float sigma) {
    float q = r / h;
    if (r <= 1e-9f * h || q >= 1.0f) {
        return 0.0f;
    }
    float f = q <= 0.5f ? q * (3.0f * q - 2.0f) : -(1.0f - q) * (1.0f - q);
    return 6.0f * sigma * f / (h * r);
}

inline int3 cell_of(float4 x, float4 origin, float inv_cell, int4 dims) {
    int3 c = convert_int3(floor((x.xyz - origin.xyz) * inv_cell));
    return clamp(c, (int3)(0), dims.xyz - 1);
}

inline int cell_index(int3 c, int4 dims) {
    return (c.z * dims.y + c.y) * dims.x + c.x;
}

__kernel void count_cells(__global const float4 *pos, __global int *cell,
                          __global volatile int *counts, float4 origin, float inv_cell,
                          int4 dims) {
    int i = get_global_id(0);
    int c = cell_index(cell_of(pos[i], origin, inv_cell, dims), dims);
    cell[i] = c;
    atomic_inc(&counts[c]);
}

// exclusive prefix sum of the counts (then zeroed for the next sort); one work-item
__kernel void scan_cells(__global int *counts, __global int *start, __global int *cursor,
                         int n_cells) {
    int s = 0;
    for (int c = 0; c < n_cells; ++c) {
        start[c] = s;
        cursor[c] = s;
        s += counts[c];
        counts[c] = 0;
    }
    start[n_cells] = s;
}

__kernel void scatter_cells(__global const int *cell, __global volatile int *cursor,
                            __global int *order) {
    int i = get_global_id(0);
    order[atomic_inc(&cursor[cell[i]])] = i;
}

// insertion sort of each cell's slots by previous index: removes the atomics' order
__kernel void sort_cells(__global const int *start, __global int *order) {
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
}

__kernel void reorder(__global const int *order, __global const float4 *pos,
                      __global const float4 *vel, __global const float *p,
                      __global const int *ids, __global float4 *pos_out,
                      __global float4 *vel_out, __global float *p_out, __global int *ids_out) {
    int s = get_global_id(0);
    int i = order[s];
    pos_out[s] = pos[i];
    vel_out[s] = vel[i];
    p_out[s] = p[i];
    ids_out[s] = ids[i];
}

// frame[ids[s]] = x[s]: back to the caller's particle order
__kernel void unsort(__global const int *ids, __global const float4 *x, __global float4 *out) {
    int s = get_global_id(0);
    out[ids[s]] = x[s];
}

// Neighbours of sorted particle i among `others` (sorted by cell, offsets `start`), in
// stencil order (z, y rows; x-contiguous ranges), skipping i itself when `self` is set.
inline int gather_neighbours(int i, float4 xi, __global const float4 *others,
                             __global const int *start, float4 origin, int4 dims,
                             float inv_cell, float h2, int self,
                             __global int *out, int max_nb) {
    int3 c = cell_of(xi, origin, inv_cell, dims);
    int x0 = max(c.x - 1, 0);
    int x1 = min(c.x + 1, dims.x - 1);
    int n = 0;
    for (int z = max(c.z - 1, 0); z <= min(c.z + 1, dims.z - 1); ++z) {
        for (int y = max(c.y - 1, 0); y <= min(c.y + 1, dims.y - 1); ++y) {
            int row = (z * dims.y + y) * dims.x;
            int end = start[row + x1 + 1];
            for (int j = start[row + x0]; j < end; ++j) {
                float3 d = xi.xyz - others[j].xyz;
                if ((self == 0 || j != i) && dot(d, d) < h2) {
                    if (n < max_nb) {
                        out[n] = j;
                    }
                    ++n;
                }
            }
        }
    }
    return n;
}

__kernel void find_neighbours(__global const float4 *pos, __global const int *start,
                              __global const float4 *walls, __global const int *wall_start,
                              GRID_ARGS, int max_nb, int max_wall_nb,
                              __global int *nb, __global int *nb_count,
                              __global int *wall_nb, __global int *wall_nb_count,
                              __global volatile int *overflow) {
    int i = get_global_id(0);
    float4 xi = pos[i];
    float h2 = h * h;
    int n = gather_neighbours(i, xi, pos, start, origin, dims, inv_cell, h2, 1,
                              nb + i * max_nb, max_nb);
    int nw = gather_neighbours(i, xi, walls, wall_start, origin, dims, inv_cell, h2, 0,
                               wall_nb + i * max_wall_nb, max_wall_nb);
    nb_count[i] = min(n, max_nb);
    wall_nb_count[i] = min(nw, max_wall_nb);
    if (n > max_nb || nw > max_wall_nb) {
        atomic_max(overflow, max(n, nw));
    }
}

// g + viscosity: fluid pairs and walls (at rest, weighted by psi as a mass: friction)
__kernel void nonpressure_accel(__global const float4 *pos, __global const float4 *vel,
                                __global const int *nb, __global const int *nb_count,
                                int max_nb, __global const float4 *walls,
                                __global const float *psi, __global const int *wall_nb,
                                __global const int *wall_nb_count, int max_wall_nb,
                                GRID_ARGS, float4 gravity, float visc, float wall_visc,
                                __global float4 *a_np) {
    int i = get_global_id(0);
    float3 xi = pos[i].xyz;
    float3 vi = vel[i].xyz;
    float eps = 0.01f * h * h;
    float3 lap = (float3)(0.0f);
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    for (int k = 0; k < n; ++k) {
        int j = list[k];
        float3 d = xi - pos[j].xyz;
        float r2 = dot(d, d);
        float coef = dot(vi - vel[j].xyz, d) / (r2 + eps);
        lap += d * (coef * kernel_grad_scale(sqrt(r2), h, sigma));
    }
    float3 wall_lap = (float3)(0.0f);
    int nw = wall_nb_count[i];
    __global const int *wlist = wall_nb + i * max_wall_nb;
    for (int k = 0; k < nw; ++k) {
        int b = wlist[k];
        float3 d = xi - walls[b].xyz;
        float r2 = dot(d, d);
        float coef = psi[b] * dot(vi, d) / (r2 + eps);
        wall_lap += d * (coef * kernel_grad_scale(sqrt(r2), h, sigma));
    }
    a_np[i] = (float4)(gravity.xyz + visc * lap + wall_visc * wall_lap, 0.0f);
}

// a_p from the pressures at x(t), then v* = (1 - damping)(v + dt (a_np + a_p)),
// x* = x + dt v*, clamped into [lo, hi] (stopping the velocity into the wall).
__kernel void pressure_predict(__global const float4 *pos, __global const float4 *vel,
                               __global const float *p, __global const float4 *a_np,
                               __global const int *nb, __global const int *nb_count,
                               int max_nb, __global const float4 *walls,
                               __global const float *psi, __global const int *wall_nb,
                               __global const int *wall_nb_count, int max_wall_nb,
                               GRID_ARGS, float inv_rho0_sq, float dt, float damping,
                               float4 lo, float4 hi, __global float4 *pos_pred,
                               __global float4 *vel_pred) {
    int i = get_global_id(0);
    float3 xi = pos[i].xyz;
    float pi = p[i];
    float3 acc = (float3)(0.0f);
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    for (int k = 0; k < n; ++k) {
        int j = list[k];
        float3 d = xi - pos[j].xyz;
        float r = length(d);
        acc -= d * ((pi + p[j]) * kernel_grad_scale(r, h, sigma));
    }
    acc *= mass * inv_rho0_sq;
    float3 wall_acc = (float3)(0.0f);
    int nw = wall_nb_count[i];
    __global const int *wlist = wall_nb + i * max_wall_nb;
    for (int k = 0; k < nw; ++k) {
        int b = wlist[k];
        float3 d = xi - walls[b].xyz;
        float r = length(d);
        wall_acc -= d * (psi[b] * kernel_grad_scale(r, h, sigma));
    }
    acc += wall_acc * (pi * inv_rho0_sq);
    float3 v = (vel[i].xyz + dt * (a_np[i].xyz + acc)) * (1.0f - damping);
    float3 x = xi + dt * v;
    v = select(v, max(v, 0.0f), isless(x, lo.xyz));
    v = select(v, min(v, 0.0f), isgreater(x, hi.xyz));
    pos_pred[i] = (float4)(clamp(x, lo.xyz, hi.xyz), 0.0f);
    vel_pred[i] = (float4)(v, 0.0f);
}

// rho* at the predicted positions, p <- max(0, p + delta (rho* - rho0)), and the max
// relative compression into err[iteration] (atomic max of non-negative float bits).
__kernel void density_pressure(__global const float4 *pos_pred, __global const int *nb,
                               __global const int *nb_count, int max_nb,
                               __global const float4 *walls, __global const float *psi,
                               __global const int *wall_nb, __global const int *wall_nb_count,
                               int max_wall_nb, GRID_ARGS, float rho0, float delta,
                               __global float *p, __global float *rho,
                               __global volatile uint *err, int iteration) {
    int i = get_global_id(0);
    float3 xi = pos_pred[i].xyz;
    float sum = kernel_w(0.0f, h, sigma);
    int n = nb_count[i];
    __global const int *list = nb + i * max_nb;
    for (int k = 0; k < n; ++k) {
        sum += kernel_w(length(xi - pos_pred[list[k]].xyz), h, sigma);
    }
    float wall_sum = 0.0f;
    int nw = wall_nb_count[i];
    __global const int *wlist = wall_nb + i * max_wall_nb;
    for (int k = 0; k < nw; ++k) {
        int b = wlist[k];
        wall_sum += psi[b] * kernel_w(length(xi - walls[b].xyz), h, sigma);
    }
    float r = mass * sum + wall_sum;
    float e = r - rho0;
    rho[i] = r;
    p[i] = max(p[i] + delta * e, 0.0f);
    atomic_max(&err[iteration], as_uint(max(e / rho0, 0.0f)));
}
