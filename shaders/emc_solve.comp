#version 430
// Extended-MC pass 1 of 1 (so far), one invocation per feature patch: the patch's feature vertex,
// core.sharp.points.patch_points (and in it _solve, _extreme_normals, feature_points) step for step.
// The planes' normals are ENO normals made here from the volume (eno_normal); a patch's vertices
// and their one-ring come as vertex lists padded with -1 (ascending, so the valid ones first).
// Writes per patch 8 doubles: point xyz, ok, corner xyz, corner found (rank 3 and finite).
layout(local_size_x = GROUP_SIZE) in;
#include "emc_common.glsl"

uniform uint u_patch_count;
uniform int u_ring_width;      // entries per ring list (patch lists have MAX_PATCH_VERTICES)
uniform double u_out_of_plane; // sqrt(1 - cos^2): a third side's normal is farther out of the plane
layout(std430, binding = BLOCK_PATCH_MEMBERS) readonly buffer PatchMembers { int patch_members[]; };
layout(std430, binding = BLOCK_RING_MEMBERS) readonly buffer RingMembers { int ring_members[]; };
layout(std430, binding = BLOCK_CELLS) readonly buffer Cells { int cells[]; };
layout(std430, binding = BLOCK_POINTS) writeonly buffer Points { double points[]; };
layout(std430, binding = BLOCK_MESH_VERTICES) readonly buffer Vertices { float vertex_data[]; };

dvec3 pos[RING_CAPACITY];
dvec3 nrm[RING_CAPACITY];
bool keep[RING_CAPACITY];

vec3 position_of(int v) {
    uint base = uint(v) * uint(VERTEX_FLOATS);
    return vec3(vertex_data[base], vertex_data[base + 1u], vertex_data[base + 2u]);
}

// Loads list entries (-1 padded) of `width` starting at `first` of the patch or ring lists: the count.
int load(bool ring, uint first, int width) {
    int count = 0;
    for (int i = 0; i < width; i++) {
        int v = ring ? ring_members[first + uint(i)] : patch_members[first + uint(i)];
        if (v < 0) break;
        vec3 p = position_of(v);
        pos[i] = dvec3(p);
        nrm[i] = eno_normal(p);
        count++;
    }
    return count;
}

int argmin_dots(int count, int seed) {
    int best = 0;
    double lowest = dot(nrm[0], nrm[seed]);
    for (int i = 1; i < count; i++) {
        double d = dot(nrm[i], nrm[seed]);
        if (d < lowest) { lowest = d; best = i; }
    }
    return best;
}

// _extreme_normals: keep[i] for the normals near one of the two or three most different ones.
void extreme_normals(int count) {
    int s1 = argmin_dots(count, 0);
    int s2 = argmin_dots(count, s1);
    dvec3 axis = cross(nrm[s1], nrm[s2]);
    axis /= max(length(axis), 1e-30lf);
    int s3 = 0;
    double farthest = abs(dot(nrm[0], axis));
    for (int i = 1; i < count; i++) {
        double d = abs(dot(nrm[i], axis));
        if (d > farthest) { farthest = d; s3 = i; }
    }
    bool third = farthest > u_out_of_plane;
    for (int i = 0; i < count; i++)
        keep[i] = dot(nrm[i], nrm[s1]) > CLUSTER_COS || dot(nrm[i], nrm[s2]) > CLUSTER_COS
                  || (third && dot(nrm[i], nrm[s3]) > CLUSTER_COS);
}

// feature_points over the kept entries: point (clamped into [lower, upper]), ok, corner, corner found, kind.
struct Solution { dvec3 point; bool ok; dvec3 corner; bool has_corner; int kind; };

Solution feature_point(int count, dvec3 lower, dvec3 upper) {
    dvec3 mass = dvec3(0.0lf);
    double weight = 0.0lf;
    for (int i = 0; i < count; i++) if (keep[i]) { mass += pos[i]; weight += 1.0lf; }
    mass /= weight;
    dmat3 m = dmat3(0.0lf);
    dvec3 r = dvec3(0.0lf);
    for (int i = 0; i < count; i++) {
        if (!keep[i]) continue;
        dvec3 a = nrm[i];
        m += outerProduct(a, a);
        r += a * dot(a, pos[i] - mass);
    }
    dvec3 values;
    dmat3 vectors;
    symmetric_eigen(m, values, vectors);
    dvec3 inv;
    int rank = 0;
    for (int j = 0; j < 3; j++) {
        bool kept = values[j] > SINGULAR_CUTOFF_SQ * values[0];
        rank += kept ? 1 : 0;
        inv[j] = kept ? 1.0lf / values[j] : 0.0lf;
    }
    dvec3 along = dvec3(dot(vectors[0], r), dot(vectors[1], r), dot(vectors[2], r));
    Solution s;
    s.corner = mass + vectors * (inv * along);
    s.has_corner = rank == 3;
    inv[2] = 0.0lf;
    dvec3 x = mass + vectors * (inv * along);
    dvec3 d = vectors[2];
    dvec3 slack = 1e-6lf * (upper - lower);
    double lo = -1.0lf / 0.0lf, hi = 1.0lf / 0.0lf;
    bool ok = rank >= 2;
    for (int k = 0; k < 3; k++) {
        if (abs(d[k]) > 1e-12lf) {
            double t0 = (lower[k] - x[k]) / d[k], t1 = (upper[k] - x[k]) / d[k];
            lo = max(lo, min(t0, t1));
            hi = min(hi, max(t0, t1));
        } else {
            ok = ok && x[k] >= lower[k] - slack[k] && x[k] <= upper[k] + slack[k];
        }
    }
    ok = ok && lo <= hi;
    if (ok) x += min(max(0.0lf, lo), hi) * d;
    bool inside = s.has_corner && all(greaterThanEqual(s.corner, lower - slack))
                  && all(lessThanEqual(s.corner, upper + slack));
    if (inside) x = s.corner;
    s.point = clamp(x, lower, upper);
    s.ok = ok || inside;
    s.kind = inside ? 3 : min(rank, 2);
    return s;
}

void main() {
    uint p = item_index();
    if (p >= u_patch_count) return;
    dvec3 lower = dvec3(cells[3u * p], cells[3u * p + 1u], cells[3u * p + 2u]) * u_spacing_d;
    dvec3 upper = (dvec3(cells[3u * p], cells[3u * p + 1u], cells[3u * p + 2u]) + 1.0lf) * u_spacing_d;

    int count = load(false, p * uint(MAX_PATCH_VERTICES), MAX_PATCH_VERTICES);
    extreme_normals(count);
    Solution own = feature_point(count, lower, upper);

    count = load(true, p * uint(u_ring_width), u_ring_width);
    extreme_normals(count);
    Solution ring = feature_point(count, lower, upper);
    bool two_sides = !ring.has_corner && ring.kind == 2;
    bool ring_ok = ring.ok && (ring.kind == 3 || two_sides);
    if (two_sides && !ring_ok) {
        dvec3 margin = LINE_MARGIN * u_spacing_d;
        Solution near = feature_point(count, lower - margin, upper + margin);
        if (near.ok) { ring.point = clamp(near.point, lower, upper); ring_ok = true; }
    }
    bool ok = own.ok && (ring_ok || !two_sides);
    dvec3 point = ring_ok ? ring.point : own.point;
    ok = ok || ring_ok;

    uint o = 8u * p;
    points[o] = point.x; points[o + 1u] = point.y; points[o + 2u] = point.z;
    points[o + 3u] = ok ? 1.0lf : 0.0lf;
    points[o + 4u] = ring.corner.x; points[o + 5u] = ring.corner.y; points[o + 6u] = ring.corner.z;
    points[o + 7u] = ring.has_corner ? 1.0lf : 0.0lf;
}
