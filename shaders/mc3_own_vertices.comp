#version 430
// The trilinear topology's pass 9, one invocation per own vertex of a cell, after pass 8 wrote every edge
// vertex: the mean of its edge vertices (pass 7's job: their indices in edge order), as
// isoscope.cpu.trilinear computes it: float32 sums in edge order, the position and value divided by the
// count, the normal by its length where that is not 0.  Each division and the square root are
// correctly rounded (rounded_quotient, rounded_root), which GLSL does not promise of `/` and `sqrt`.
layout(local_size_x = GROUP_SIZE) in;
#include "mc_common.glsl"

uniform uint u_own_base;   // the first own vertex: the edge vertices' total
uniform uint u_own_count;
layout(std430, binding = BLOCK_OWN_JOBS) readonly buffer OwnJobs { uint own_jobs[]; };
struct Vertex { vec4 position_value; vec4 normal; };
layout(std430, binding = BLOCK_MESH_VERTICES) buffer Vertices { Vertex vertices[]; };

// The float nearest a / b (ties to even): the double quotient's float, then moved by one step where the
// exact test says the true quotient lies past a midpoint (m * b is exact in double for floats m, b).
float rounded_quotient(float a, float b) {
    float q = float(double(a) / double(b));
    precise double x = abs(double(a)), y = abs(double(b));
    float m = abs(q);
    float up = uintBitsToFloat(floatBitsToUint(m) + 1u), down = m > 0.0 ? uintBitsToFloat(floatBitsToUint(m) - 1u) : 0.0;
    precise double high = (double(m) + double(up)) * 0.5LF * y, low = (double(m) + double(down)) * 0.5LF * y;
    if (high < x || (high == x && (floatBitsToUint(m) & 1u) != 0u)) m = up;
    else if (low > x || (low == x && (floatBitsToUint(m) & 1u) != 0u)) m = down;
    return uintBitsToFloat(floatBitsToUint(m) | ((floatBitsToUint(a) ^ floatBitsToUint(b)) & 0x80000000u));
}

// The float nearest sqrt(a), a >= 0, the same way (m * m is exact in double).
float rounded_root(float a) {
    float r = float(sqrt(double(a)));
    float up = uintBitsToFloat(floatBitsToUint(r) + 1u), down = r > 0.0 ? uintBitsToFloat(floatBitsToUint(r) - 1u) : 0.0;
    precise double high = (double(r) + double(up)) * 0.5LF, low = (double(r) + double(down)) * 0.5LF;
    precise double high2 = high * high, low2 = low * low;
    if (high2 < double(a)) r = up;
    else if (low2 > double(a)) r = down;
    return r;
}

void main() {
    uint o = linear_group() * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (o >= u_own_count) return;
    precise vec3 p = vec3(0.0), n = vec3(0.0);
    precise float value = 0.0;
    uint count = 0u;
    for (; count < OWN_EDGES; ++count) {
        uint v = own_jobs[o * OWN_EDGES + count];
        if (v == 0xFFFFFFFFu) break;
        Vertex edge = vertices[v];
        p += edge.position_value.xyz;
        n += edge.normal.xyz;
        value += edge.position_value.w;
    }
    float many = float(count);
    precise float squares = n.x * n.x + n.y * n.y + n.z * n.z;
    float norm = rounded_root(squares);
    vec3 normal = n;
    if (norm > 0.0) normal = vec3(rounded_quotient(n.x, norm), rounded_quotient(n.y, norm), rounded_quotient(n.z, norm));
    Vertex v;
    v.position_value = vec4(rounded_quotient(p.x, many), rounded_quotient(p.y, many), rounded_quotient(p.z, many),
                            rounded_quotient(value, many));
    v.normal = vec4(normal, 0.0);
    vertices[u_own_base + o] = v;
}
