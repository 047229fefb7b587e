// numpy's answers where GLSL leaves the maths undefined, so the GPU and the
// CPU back ends of app/volumes/expression.py agree (NaN/Inf are then reported
// to the user by the volume checks, with a fix).
float ex_nan() { return uintBitsToFloat(0x7fc00000u); }
float ex_inf() { return uintBitsToFloat(0x7f800000u); }

float ex_log(float a) { return a < 0.0 ? ex_nan() : (a == 0.0 ? -ex_inf() : log(a)); }
float ex_sqrt(float a) { return a < 0.0 ? ex_nan() : sqrt(a); }
float ex_min(float a, float b) { return (isnan(a) || isnan(b)) ? ex_nan() : min(a, b); }
float ex_max(float a, float b) { return (isnan(a) || isnan(b)) ? ex_nan() : max(a, b); }

// pow(a, b) is undefined in GLSL for a < 0 and for a == 0, b <= 0.
float ex_pow(float a, float b) {
    if (b == 0.0) return 1.0;
    if (isnan(a) || isnan(b)) return ex_nan();
    if (a == 0.0) return b > 0.0 ? 0.0 : ex_inf();
    if (a < 0.0) {
        if (b != floor(b)) return ex_nan();
        float magnitude = pow(-a, b);
        return mod(b, 2.0) == 1.0 ? -magnitude : magnitude;
    }
    return pow(a, b);
}
