// Shared by the Extended-MC passes (isoscope.gpu.sharp; numpy mirror: isoscope.core.sharp).
//
// All geometry here is double precision, as the numpy reference's: the feature point is a
// least-squares solve whose matrix can be near singular, and the GPU's point must agree with
// numpy's to ~1e-6 of a cell.  JACOBI_SWEEPS, SINGULAR_CUTOFF_SQ, CLUSTER_COS (cos CLUSTER_ANGLE)
// and LINE_MARGIN are #defines from isoscope.core.sharp (qef.py, points.py).
#include "mc_common.glsl"

uniform dvec3 u_spacing_d;     // the spacing, in double (u_spacing is its float rounding)

uint item_index() { return linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex; }

// core.sharp.eno.eno_gradient at grid point q: per axis the one-sided difference of the smoother side.
dvec3 eno_gradient(ivec3 q) {
    dvec3 grad;
    for (int axis = 0; axis < 3; axis++) {
        ivec3 e = ivec3(0);
        e[axis] = 1;
        int n = u_dims[axis], k = q[axis];
        ivec3 lo = ivec3(0), hi = u_dims - 1;
        double f0 = double(field_at(q));
        double fp = double(field_at(clamp(q + e, lo, hi))), fm = double(field_at(clamp(q - e, lo, hi)));
        double fpp = double(field_at(clamp(q + 2 * e, lo, hi))), fmm = double(field_at(clamp(q - 2 * e, lo, hi)));
        bool has_fwd = k + 2 < n, has_bwd = k - 2 >= 0;
        double rough_fwd = abs(fpp - 2.0lf * fp + f0), rough_bwd = abs(f0 - 2.0lf * fm + fmm);
        bool fwd_smoother = has_fwd && (!has_bwd || rough_fwd < rough_bwd);
        bool use_fwd = k == 0 || (k + 1 < n && fwd_smoother);
        grad[axis] = (use_fwd ? fp - f0 : f0 - fm) / u_spacing_d[axis];
    }
    return grad;
}

// core.sharp.eno.eno_normals of a vertex at `position`: ENO gradients at its edge's ends, interpolated.
dvec3 eno_normal(vec3 position) {
    dvec3 g = dvec3(position) / u_spacing_d;
    dvec3 nearest = roundEven(g);
    bvec3 along = greaterThan(abs(g - nearest), dvec3(1e-3lf));
    dvec3 start = mix(nearest, floor(g), along);
    int axis = along.x ? 0 : (along.y ? 1 : 2);
    double t = g[axis] - start[axis];
    ivec3 s = ivec3(start), step = ivec3(along);
    precise dvec3 grad = eno_gradient(s) * (1.0lf - t) + eno_gradient(s + step) * t;
    double len = length(grad);
    return len > 0.0lf ? -grad / len : dvec3(0.0lf);
}

// core.sharp.qef.symmetric_eigen: eigenvalues descending, eigenvectors as the columns of `vectors`.
void symmetric_eigen(dmat3 m, out dvec3 values, out dmat3 vectors) {
    dmat3 a = m, v = dmat3(1.0lf);
    for (int sweep = 0; sweep < JACOBI_SWEEPS; sweep++) {
        for (int r = 0; r < 3; r++) {
            int p = r == 2 ? 1 : 0, q = r == 0 ? 1 : 2;  // (0, 1), (0, 2), (1, 2)
            double apq = a[q][p];
            if (apq == 0.0lf) continue;
            double theta = (a[q][q] - a[p][p]) / (2.0lf * apq);
            double t = (theta >= 0.0lf ? 1.0lf : -1.0lf) / (abs(theta) + sqrt(theta * theta + 1.0lf));
            double c = 1.0lf / sqrt(t * t + 1.0lf), s = t * c;
            dmat3 j = dmat3(1.0lf);
            j[p][p] = c; j[q][q] = c; j[q][p] = s; j[p][q] = -s;  // numpy's j[p, q] = s, j[q, p] = -s
            a = transpose(j) * a * j;
            v = v * j;
        }
    }
    values = dvec3(a[0][0], a[1][1], a[2][2]);
    vectors = v;
    // A stable sort, descending (numpy's argsort(-values, kind="stable")).
    for (int pass = 0; pass < 3; pass++) {
        int i = pass == 1 ? 1 : 0;
        if (values[i + 1] > values[i]) {
            double x = values[i]; values[i] = values[i + 1]; values[i + 1] = x;
            dvec3 y = vectors[i]; vectors[i] = vectors[i + 1]; vectors[i + 1] = y;
        }
    }
}
