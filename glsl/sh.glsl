// Colour from spherical harmonics of degree 0..3 (SPEC section 3), in the INRIA term order.
// `sh` holds the Gaussian's coefficients coefficient-major: value base + 3 * k + channel,
// 32-bit floats or (with SH_HALF) half floats.
#ifndef RARA_SH_GLSL
#define RARA_SH_GLSL

const float SH_C0 = 0.28209479177387814;
const float SH_C1 = 0.4886025119029199;
const float SH_C2[5] = float[5](1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                                -1.0925484305920792, 0.5462742152960396);
const float SH_C3[7] = float[7](-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
                                0.3731763325901154, -0.4570457994644658, 1.445305721320277,
                                -0.5900435899266435);

#ifdef SH_HALF
// Half floats, two to a uint: value i is the low (even i) or high half of word i / 2.
#define ShCoefficients U32s
float sh_value(ShCoefficients sh, uint i) {
    vec2 pair = unpackHalf2x16(sh.v[i >> 1u]);
    return (i & 1u) == 0u ? pair.x : pair.y;
}
#else
#define ShCoefficients F32s
float sh_value(ShCoefficients sh, uint i) { return sh.v[i]; }
#endif

vec3 sh_coef(ShCoefficients sh, uint base, uint k) {
    uint i = base + 3u * k;
    return vec3(sh_value(sh, i), sh_value(sh, i + 1u), sh_value(sh, i + 2u));
}

// SH_DEGREE, the scene's degree, is fixed per kernel (project_deg*.comp): a CPU driver would
// otherwise run every band's loads and sums under a mask whatever the scene's degree (plant,
// degree 0: the project pass 30 -> 24 ms without the masked bands 1-3).
vec3 eval_sh(ShCoefficients sh, uint base, vec3 dir) {
    vec3 result = SH_C0 * sh_coef(sh, base, 0u);
#if SH_DEGREE > 0
    float x = dir.x, y = dir.y, z = dir.z;
    result = result - SH_C1 * y * sh_coef(sh, base, 1u) + SH_C1 * z * sh_coef(sh, base, 2u)
             - SH_C1 * x * sh_coef(sh, base, 3u);
#if SH_DEGREE > 1
    float xx = x * x, yy = y * y, zz = z * z;
    float xy = x * y, yz = y * z, xz = x * z;
    result = result + SH_C2[0] * xy * sh_coef(sh, base, 4u)
             + SH_C2[1] * yz * sh_coef(sh, base, 5u)
             + SH_C2[2] * (2.0 * zz - xx - yy) * sh_coef(sh, base, 6u)
             + SH_C2[3] * xz * sh_coef(sh, base, 7u)
             + SH_C2[4] * (xx - yy) * sh_coef(sh, base, 8u);
#if SH_DEGREE > 2
    result = result + SH_C3[0] * y * (3.0 * xx - yy) * sh_coef(sh, base, 9u)
             + SH_C3[1] * xy * z * sh_coef(sh, base, 10u)
             + SH_C3[2] * y * (4.0 * zz - xx - yy) * sh_coef(sh, base, 11u)
             + SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh_coef(sh, base, 12u)
             + SH_C3[4] * x * (4.0 * zz - xx - yy) * sh_coef(sh, base, 13u)
             + SH_C3[5] * z * (xx - yy) * sh_coef(sh, base, 14u)
             + SH_C3[6] * x * (xx - 3.0 * yy) * sh_coef(sh, base, 15u);
#endif
#endif
#endif
    return max(result + 0.5, vec3(0.0));
}

#endif
