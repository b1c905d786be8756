// The summed step's kept weights (deon_gather_weights.frag, WEIGHT_TEXTURES of them: 4 weights a texel)
// and WEIGHTS_AT(W, OFF, P): W[OFF + t] = weight texture t at texel P. Once a shader.
#ifndef SKINVIEWER_GATHER_WEIGHT_MAPS_GLSL
#define SKINVIEWER_GATHER_WEIGHT_MAPS_GLSL
#ifndef WEIGHT_TEXTURES
#define WEIGHT_TEXTURES 19
#endif
#if WEIGHT_TEXTURES > 0
uniform sampler2D w0;
#define WEIGHT_AT_0(W, OFF, P) W[(OFF) + 0] = texelFetch(w0, P, 0);
#else
#define WEIGHT_AT_0(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 1
uniform sampler2D w1;
#define WEIGHT_AT_1(W, OFF, P) W[(OFF) + 1] = texelFetch(w1, P, 0);
#else
#define WEIGHT_AT_1(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 2
uniform sampler2D w2;
#define WEIGHT_AT_2(W, OFF, P) W[(OFF) + 2] = texelFetch(w2, P, 0);
#else
#define WEIGHT_AT_2(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 3
uniform sampler2D w3;
#define WEIGHT_AT_3(W, OFF, P) W[(OFF) + 3] = texelFetch(w3, P, 0);
#else
#define WEIGHT_AT_3(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 4
uniform sampler2D w4;
#define WEIGHT_AT_4(W, OFF, P) W[(OFF) + 4] = texelFetch(w4, P, 0);
#else
#define WEIGHT_AT_4(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 5
uniform sampler2D w5;
#define WEIGHT_AT_5(W, OFF, P) W[(OFF) + 5] = texelFetch(w5, P, 0);
#else
#define WEIGHT_AT_5(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 6
uniform sampler2D w6;
#define WEIGHT_AT_6(W, OFF, P) W[(OFF) + 6] = texelFetch(w6, P, 0);
#else
#define WEIGHT_AT_6(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 7
uniform sampler2D w7;
#define WEIGHT_AT_7(W, OFF, P) W[(OFF) + 7] = texelFetch(w7, P, 0);
#else
#define WEIGHT_AT_7(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 8
uniform sampler2D w8;
#define WEIGHT_AT_8(W, OFF, P) W[(OFF) + 8] = texelFetch(w8, P, 0);
#else
#define WEIGHT_AT_8(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 9
uniform sampler2D w9;
#define WEIGHT_AT_9(W, OFF, P) W[(OFF) + 9] = texelFetch(w9, P, 0);
#else
#define WEIGHT_AT_9(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 10
uniform sampler2D w10;
#define WEIGHT_AT_10(W, OFF, P) W[(OFF) + 10] = texelFetch(w10, P, 0);
#else
#define WEIGHT_AT_10(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 11
uniform sampler2D w11;
#define WEIGHT_AT_11(W, OFF, P) W[(OFF) + 11] = texelFetch(w11, P, 0);
#else
#define WEIGHT_AT_11(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 12
uniform sampler2D w12;
#define WEIGHT_AT_12(W, OFF, P) W[(OFF) + 12] = texelFetch(w12, P, 0);
#else
#define WEIGHT_AT_12(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 13
uniform sampler2D w13;
#define WEIGHT_AT_13(W, OFF, P) W[(OFF) + 13] = texelFetch(w13, P, 0);
#else
#define WEIGHT_AT_13(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 14
uniform sampler2D w14;
#define WEIGHT_AT_14(W, OFF, P) W[(OFF) + 14] = texelFetch(w14, P, 0);
#else
#define WEIGHT_AT_14(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 15
uniform sampler2D w15;
#define WEIGHT_AT_15(W, OFF, P) W[(OFF) + 15] = texelFetch(w15, P, 0);
#else
#define WEIGHT_AT_15(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 16
uniform sampler2D w16;
#define WEIGHT_AT_16(W, OFF, P) W[(OFF) + 16] = texelFetch(w16, P, 0);
#else
#define WEIGHT_AT_16(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 17
uniform sampler2D w17;
#define WEIGHT_AT_17(W, OFF, P) W[(OFF) + 17] = texelFetch(w17, P, 0);
#else
#define WEIGHT_AT_17(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 18
uniform sampler2D w18;
#define WEIGHT_AT_18(W, OFF, P) W[(OFF) + 18] = texelFetch(w18, P, 0);
#else
#define WEIGHT_AT_18(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 19
uniform sampler2D w19;
#define WEIGHT_AT_19(W, OFF, P) W[(OFF) + 19] = texelFetch(w19, P, 0);
#else
#define WEIGHT_AT_19(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 20
uniform sampler2D w20;
#define WEIGHT_AT_20(W, OFF, P) W[(OFF) + 20] = texelFetch(w20, P, 0);
#else
#define WEIGHT_AT_20(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 21
uniform sampler2D w21;
#define WEIGHT_AT_21(W, OFF, P) W[(OFF) + 21] = texelFetch(w21, P, 0);
#else
#define WEIGHT_AT_21(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 22
uniform sampler2D w22;
#define WEIGHT_AT_22(W, OFF, P) W[(OFF) + 22] = texelFetch(w22, P, 0);
#else
#define WEIGHT_AT_22(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 23
uniform sampler2D w23;
#define WEIGHT_AT_23(W, OFF, P) W[(OFF) + 23] = texelFetch(w23, P, 0);
#else
#define WEIGHT_AT_23(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 24
uniform sampler2D w24;
#define WEIGHT_AT_24(W, OFF, P) W[(OFF) + 24] = texelFetch(w24, P, 0);
#else
#define WEIGHT_AT_24(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 25
uniform sampler2D w25;
#define WEIGHT_AT_25(W, OFF, P) W[(OFF) + 25] = texelFetch(w25, P, 0);
#else
#define WEIGHT_AT_25(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 26
uniform sampler2D w26;
#define WEIGHT_AT_26(W, OFF, P) W[(OFF) + 26] = texelFetch(w26, P, 0);
#else
#define WEIGHT_AT_26(W, OFF, P)
#endif
#if WEIGHT_TEXTURES > 27
uniform sampler2D w27;
#define WEIGHT_AT_27(W, OFF, P) W[(OFF) + 27] = texelFetch(w27, P, 0);
#else
#define WEIGHT_AT_27(W, OFF, P)
#endif
#define WEIGHTS_AT(W, OFF, P) WEIGHT_AT_0(W, OFF, P) WEIGHT_AT_1(W, OFF, P) WEIGHT_AT_2(W, OFF, P) WEIGHT_AT_3(W, OFF, P) WEIGHT_AT_4(W, OFF, P) WEIGHT_AT_5(W, OFF, P) WEIGHT_AT_6(W, OFF, P) WEIGHT_AT_7(W, OFF, P) WEIGHT_AT_8(W, OFF, P) WEIGHT_AT_9(W, OFF, P) WEIGHT_AT_10(W, OFF, P) WEIGHT_AT_11(W, OFF, P) WEIGHT_AT_12(W, OFF, P) WEIGHT_AT_13(W, OFF, P) WEIGHT_AT_14(W, OFF, P) WEIGHT_AT_15(W, OFF, P) WEIGHT_AT_16(W, OFF, P) WEIGHT_AT_17(W, OFF, P) WEIGHT_AT_18(W, OFF, P) WEIGHT_AT_19(W, OFF, P) WEIGHT_AT_20(W, OFF, P) WEIGHT_AT_21(W, OFF, P) WEIGHT_AT_22(W, OFF, P) WEIGHT_AT_23(W, OFF, P) WEIGHT_AT_24(W, OFF, P) WEIGHT_AT_25(W, OFF, P) WEIGHT_AT_26(W, OFF, P) WEIGHT_AT_27(W, OFF, P)
#endif
