// Every operation of a user expression, computed exactly as app/volumes/expression.py's
// numpy `evaluate` does, so the GPU and CPU back ends agree sample for sample, NaN and Inf
// included (they are then reported to the user by the volume checks, with a fix).
//
// GLSL leaves division by zero, log/sqrt/pow outside their domain and builtins of NaN/Inf
// undefined, lets the compiler fold 0*v to 0, v-v to 0 and fuse a*b+c, and lets the driver
// keep or flush denormals.  So here: every special case is decided with exact comparisons
// and bit tests (never isnan(), which a compiler may assume false), each result is a
// `precise` variable (no folding, no fusing), and every result below the smallest normal
// float is flushed to a zero of its sign (numpy does the same after each operation).

const uint EX_SIGN = 0x80000000u;
const uint EX_ABS = 0x7fffffffu;
const uint EX_EXPONENT = 0x7f800000u;

float ex_nan() { return uintBitsToFloat(0x7fc00000u); }
float ex_inf() { return uintBitsToFloat(EX_EXPONENT); }
bool ex_isnan(float a) { return (floatBitsToUint(a) & EX_ABS) > EX_EXPONENT; }
bool ex_isinf(float a) { return (floatBitsToUint(a) & EX_ABS) == EX_EXPONENT; }
bool ex_finite(float a) { return (floatBitsToUint(a) & EX_EXPONENT) != EX_EXPONENT; }
bool ex_iszero(float a) { return (floatBitsToUint(a) & EX_ABS) == 0u; }
bool ex_negative(float a) { return (floatBitsToUint(a) & EX_SIGN) != 0u; }  // the sign bit, -0 included
// |magnitude| with the sign bit `sign` (0u or EX_SIGN)
float ex_signed(float magnitude, uint sign) { return uintBitsToFloat((floatBitsToUint(magnitude) & EX_ABS) | sign); }
uint ex_sign_xor(float a, float b) { return (floatBitsToUint(a) ^ floatBitsToUint(b)) & EX_SIGN; }

float ex_ftz(float a) {
    uint bits = floatBitsToUint(a);
    return (bits & EX_EXPONENT) == 0u ? uintBitsToFloat(bits & EX_SIGN) : a;
}

float ex_neg(float a) { return uintBitsToFloat(floatBitsToUint(a) ^ EX_SIGN); }
float ex_abs(float a) { return uintBitsToFloat(floatBitsToUint(a) & EX_ABS); }

float ex_add(float a, float b) { precise float r = a + b; return ex_ftz(r); }
float ex_sub(float a, float b) { precise float r = a - b; return ex_ftz(r); }
float ex_mul(float a, float b) { precise float r = a * b; return ex_ftz(r); }

float ex_div(float a, float b) {
    if (ex_isnan(a) || ex_isnan(b)) return ex_nan();
    uint sign = ex_sign_xor(a, b);
    if (ex_iszero(b)) return ex_iszero(a) ? ex_nan() : ex_signed(ex_inf(), sign);
    if (ex_isinf(b)) return ex_isinf(a) ? ex_nan() : ex_signed(0.0, sign);
    if (ex_isinf(a)) return ex_signed(ex_inf(), sign);
    // Finite, b normal.  A driver may divide as a * (1/b): 1/b is then denormal (flushed)
    // for |b| > 2^126, so scale both down first; the quotient is the same.
    precise float n = a;
    precise float d = b;
    if (abs(d) > 8.5070592e37) { n = n * 0.25; d = d * 0.25; }
    precise float r = n / d;
    return ex_ftz(r);
}

float ex_sin(float a) { if (!ex_finite(a)) return ex_nan(); precise float r = sin(a); return ex_ftz(r); }
float ex_cos(float a) { if (!ex_finite(a)) return ex_nan(); precise float r = cos(a); return ex_ftz(r); }
float ex_tan(float a) { if (!ex_finite(a)) return ex_nan(); precise float r = tan(a); return ex_ftz(r); }

float ex_exp(float a) {
    if (ex_isnan(a)) return ex_nan();
    if (a > 88.8) return ex_inf();    // exp(88.73) overflows float32
    if (a < -88.0) return 0.0;        // exp(-87.34) is the smallest normal float32: below, flushed
    precise float r = exp(a);
    return ex_ftz(r);
}

float ex_log(float a) {
    if (ex_isnan(a) || (ex_negative(a) && !ex_iszero(a))) return ex_nan();
    if (ex_iszero(a)) return -ex_inf();
    if (ex_isinf(a)) return ex_inf();
    precise float r = log(a);
    return ex_ftz(r);
}

float ex_sqrt(float a) {
    if (ex_isnan(a) || (ex_negative(a) && !ex_iszero(a))) return ex_nan();
    if (ex_iszero(a) || ex_isinf(a)) return a;  // sqrt(-0) is -0
    precise float r = sqrt(a);
    return ex_ftz(r);
}

// IEEE 754-2019 minimum/maximum: NaN if either is NaN, -0 below +0.
float ex_min(float a, float b) {
    if (ex_isnan(a) || ex_isnan(b)) return ex_nan();
    if (a == b) return uintBitsToFloat(floatBitsToUint(a) | floatBitsToUint(b));
    return a < b ? a : b;
}

float ex_max(float a, float b) {
    if (ex_isnan(a) || ex_isnan(b)) return ex_nan();
    if (a == b) return uintBitsToFloat(floatBitsToUint(a) & floatBitsToUint(b));
    return a > b ? a : b;
}

bool ex_integer(float b) { return ex_finite(b) && floor(b) == b; }
bool ex_odd_integer(float b) { return abs(b) < 16777216.0 && ex_integer(b) && fract(b * 0.5) == 0.5; }

// C99 pow, as numpy's float32 power (powf) computes it; GLSL's pow is undefined for a < 0,
// for a == 0 with b <= 0, and for NaN or Inf.  Otherwise exp2(b * log2|a|): within a few
// float32 ulps of powf (more for results near the overflow threshold).
float ex_pow(float a, float b) {
    if (ex_iszero(b) || a == 1.0) return 1.0;
    // The commonest powers exactly as numpy's evaluate computes them: a*a, a, 1/a.
    if (b == 2.0) { precise float square = a * a; return ex_ftz(square); }
    if (b == 1.0) return a;
    if (b == -1.0) return ex_div(1.0, a);
    if (ex_isnan(a) || ex_isnan(b)) return ex_nan();
    bool odd = ex_odd_integer(b);
    if (ex_iszero(a)) {
        if (b < 0.0) return odd ? ex_signed(ex_inf(), floatBitsToUint(a) & EX_SIGN) : ex_inf();
        return odd ? a : 0.0;
    }
    if (ex_isinf(b)) {
        if (a == -1.0) return 1.0;
        return ((abs(a) < 1.0) == (b < 0.0)) ? ex_inf() : 0.0;
    }
    if (ex_isinf(a)) {
        uint sign = (ex_negative(a) && odd) ? EX_SIGN : 0u;
        return ex_signed(b < 0.0 ? 0.0 : ex_inf(), sign);
    }
    if (ex_negative(a) && !ex_integer(b)) return ex_nan();
    precise float magnitude;
    precise float e = b * log2(abs(a));
    if (e >= 128.0) magnitude = ex_inf();
    else if (e < -127.0) magnitude = 0.0;   // below the smallest normal: flushed
    else magnitude = exp2(e);
    return ex_ftz(ex_negative(a) && odd ? -magnitude : magnitude);
}
