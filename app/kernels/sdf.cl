// Zhu and Bridson (2005) signed distance of a particle surface on a voxel grid.
// NumPy twin: app/core/surface.py (zhu_bridson_sdf; see there for the maths).
//
// One work-item per voxel gathers the particles of the 3 x 3 x 3 bins around it (bins of
// edge R, particles sorted by bin on the host), so there are no atomics and the output
// is reproducible. Write a*b+c, never fma()/mad(): both are ~8x slower on PoCL's CPU.

__kernel void zhu_bridson_sdf(__global const float4 *pos, __global const int *bin_start,
                              float4 bin_origin, int4 bin_dims, float4 grid_origin,
                              int4 grid_shape, float voxel, float search_radius,
                              float particle_radius, __global float *phi) {
    int v = get_global_id(0);
    int nz = grid_shape.z;
    int ny = grid_shape.y;
    int3 idx = (int3)(v / (ny * nz), (v / nz) % ny, v % nz);
    float3 x = grid_origin.xyz + (convert_float3(idx) + 0.5f) * voxel;
    float inv_r2 = 1.0f / (search_radius * search_radius);
    int3 b = convert_int3(floor((x - bin_origin.xyz) / search_radius));
    float sw = 0.0f;
    float3 sd = (float3)(0.0f);  // weighted sum of p_j - x: exact near x in float32
    for (int bz = max(b.z - 1, 0); bz <= min(b.z + 1, bin_dims.z - 1); ++bz) {
        for (int by = max(b.y - 1, 0); by <= min(b.y + 1, bin_dims.y - 1); ++by) {
            for (int bx = max(b.x - 1, 0); bx <= min(b.x + 1, bin_dims.x - 1); ++bx) {
                int c = (bz * bin_dims.y + by) * bin_dims.x + bx;
                for (int j = bin_start[c]; j < bin_start[c + 1]; ++j) {
                    float3 d = pos[j].xyz - x;
                    float s = 1.0f - dot(d, d) * inv_r2;
                    if (s > 0.0f) {
                        float w = s * s * s;
                        sw += w;
                        sd += w * d;
                    }
                }
            }
        }
    }
    phi[v] = sw > 0.0f ? length(sd / sw) - particle_radius
                       : search_radius - particle_radius;
}
