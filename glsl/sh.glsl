// Colour from spherical harmonics of degree 0..3 (SPEC section 3), in the INRIA term order.
// `sh` holds the Gaussian's coefficients coefficient-major: value base + 3 * k + channel,
// 32-bit floats or (with SH_HALF) half floats.
#extension GL_EXT_control_flow_attributes : require
#ifdef SCENE_TEXELS
#extension GL_EXT_samplerless_texture_functions : require
#endif
#ifndef RARA_SH_GLSL
#define RARA_SH_GLSL

const float SH_C0 = 0.28209479177387814;
const float SH_C1 = 0.4886025119029199;
const float SH_C2[5] = float[5](1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                                -1.0925484305920792, 0.5462742152960396);
const float SH_C3[7] = float[7](-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
                                0.3731763325901154, -0.4570457994644658, 1.445305721320277,
                                -0.5900435899266435);

#define SH_VALUES (3 * (SH_DEGREE + 1) * (SH_DEGREE + 1))

// The Gaussian's SH_VALUES coefficients, starting at value `base`. They are read as aligned
// 64-bit words (two floats or four half floats each): a CPU driver pays one scalar loop over
// the SIMD lanes per buffer-reference load, so this is half the loops of 32-bit loads (a
// quarter for half floats). A Gaussian's values need not start on a word: the words from the
// one holding value `base` are loaded, and `skip` (the values of that word before `base`)
// picks each value. The last Gaussian's words may reach up to 10 bytes past its values, which
// the buffer holds (GpuScene::SH_TAIL_BYTES in src/renderer.rs).
#ifdef SH_HALF
// Half floats, four to a 64-bit word.
#define ShCoefficients U32s
#define SH_PER_WORD 4
#define SH_VALUE_BYTES 2u
#else
#define ShCoefficients F32s
#define SH_PER_WORD 2
#define SH_VALUE_BYTES 4u
#endif
#if SH_VALUES % SH_PER_WORD == 0
// Every Gaussian's values start on a word.
#define SH_WORDS (SH_VALUES / SH_PER_WORD)
#else
// Words that hold SH_VALUES values starting anywhere in the first.
#define SH_WORDS ((SH_VALUES + 2 * (SH_PER_WORD - 1)) / SH_PER_WORD)
#endif

#ifdef SCENE_TEXELS
// The same from the scene's texel view of the coefficients (sh_texels in frame_texels.glsl;
// CPU drivers): texels of four values, RGBA32_UINT for floats, RG32_UINT for half floats. A
// texel fetch is a gather where a buffer load is a scalar loop over the lanes. The Gaussian's
// values start `skip` values into its first texel; the fetches stop at the view's last texel
// (the values past the scene's last are not used).
#include "frame_texels.glsl"
#if SH_VALUES % 4 == 0
#define SH_TEXELS (SH_VALUES / 4)
#else
#define SH_TEXELS ((SH_VALUES + 6) / 4)
#endif

void load_sh(uint base, out float values[SH_VALUES]) {
    uint skip = base % 4u;
    int first = int(base / 4u);
    int last = textureSize(sh_texels) - 1;
    float packed[SH_TEXELS * 4];
    [[unroll]] for (int j = 0; j < SH_TEXELS; ++j) {
        uvec4 t = texelFetch(sh_texels, min(first + j, last));
#ifdef SH_HALF
        vec2 lo = unpackHalf2x16(t.x);
        vec2 hi = unpackHalf2x16(t.y);
        packed[4 * j] = lo.x;
        packed[4 * j + 1] = lo.y;
        packed[4 * j + 2] = hi.x;
        packed[4 * j + 3] = hi.y;
#else
        packed[4 * j] = uintBitsToFloat(t.x);
        packed[4 * j + 1] = uintBitsToFloat(t.y);
        packed[4 * j + 2] = uintBitsToFloat(t.z);
        packed[4 * j + 3] = uintBitsToFloat(t.w);
#endif
    }
    [[unroll]] for (uint k = 0u; k < uint(SH_VALUES); ++k) {
        float v = packed[k];
#if SH_VALUES % 4 != 0
        [[unroll]] for (uint o = 1u; o < 4u; ++o) {
            v = skip == o ? packed[k + o] : v;
        }
#endif
        values[k] = v;
    }
}
#define LOAD_SH(sh, base, values) load_sh(base, values)
#else
#define LOAD_SH(sh, base, values) load_sh(sh, base, values)

void load_sh(ShCoefficients sh, uint base, out float values[SH_VALUES]) {
    uint skip = base % uint(SH_PER_WORD);
    Pairs64 words = Pairs64(address_item(Address(sh), base - skip, SH_VALUE_BYTES));
    float packed[SH_WORDS * SH_PER_WORD];
    [[unroll]] for (uint j = 0u; j < uint(SH_WORDS); ++j) {
        uvec2 w = pair64_words(words.v[j]);
#ifdef SH_HALF
        vec2 lo = unpackHalf2x16(w.x);
        vec2 hi = unpackHalf2x16(w.y);
        packed[4u * j] = lo.x;
        packed[4u * j + 1u] = lo.y;
        packed[4u * j + 2u] = hi.x;
        packed[4u * j + 3u] = hi.y;
#else
        packed[2u * j] = uintBitsToFloat(w.x);
        packed[2u * j + 1u] = uintBitsToFloat(w.y);
#endif
    }
    [[unroll]] for (uint k = 0u; k < uint(SH_VALUES); ++k) {
        float v = packed[k];
#if SH_VALUES % SH_PER_WORD != 0
        [[unroll]] for (uint o = 1u; o < uint(SH_PER_WORD); ++o) {
            v = skip == o ? packed[k + o] : v;
        }
#endif
        values[k] = v;
    }
}

#endif

// Coefficient k (its three channels) of the loaded values.
#define SH_COEF(k) vec3(values[3u * (k)], values[3u * (k) + 1u], values[3u * (k) + 2u])

// SH_DEGREE, the scene's degree, is fixed per kernel (project_deg*): a CPU driver would
// otherwise run every band's loads and sums under a mask whatever the scene's degree (plant,
// degree 0: the project pass 30 -> 24 ms without the masked bands 1-3).
vec3 eval_sh(ShCoefficients sh, uint base, vec3 dir) {
    float values[SH_VALUES];
    LOAD_SH(sh, base, values);
    vec3 result = SH_C0 * SH_COEF(0u);
#if SH_DEGREE > 0
    float x = dir.x, y = dir.y, z = dir.z;
    result = result - SH_C1 * y * SH_COEF(1u) + SH_C1 * z * SH_COEF(2u)
             - SH_C1 * x * SH_COEF(3u);
#if SH_DEGREE > 1
    float xx = x * x, yy = y * y, zz = z * z;
    float xy = x * y, yz = y * z, xz = x * z;
    result = result + SH_C2[0] * xy * SH_COEF(4u)
             + SH_C2[1] * yz * SH_COEF(5u)
             + SH_C2[2] * (2.0 * zz - xx - yy) * SH_COEF(6u)
             + SH_C2[3] * xz * SH_COEF(7u)
             + SH_C2[4] * (xx - yy) * SH_COEF(8u);
#if SH_DEGREE > 2
    result = result + SH_C3[0] * y * (3.0 * xx - yy) * SH_COEF(9u)
             + SH_C3[1] * xy * z * SH_COEF(10u)
             + SH_C3[2] * y * (4.0 * zz - xx - yy) * SH_COEF(11u)
             + SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * SH_COEF(12u)
             + SH_C3[4] * x * (4.0 * zz - xx - yy) * SH_COEF(13u)
             + SH_C3[5] * z * (xx - yy) * SH_COEF(14u)
             + SH_C3[6] * x * (xx - 3.0 * yy) * SH_COEF(15u);
#endif
#endif
#endif
    return max(result + 0.5, vec3(0.0));
}

#endif
