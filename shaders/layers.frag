#version 410 core
// Layers of a layered picture composed in one pass (fmr_editor/render/picture_renderer.py), bottom first, each
//     out = m S(V) + (1 - m) below,  m = clamp(a, 0, 1) * opacity * clamp(M, 0, 1), 0 or 1 within u_negligible,
//     M = base + luma . mask colour (or 1 - that),  a = the alpha field's first channel (1 for an opaque layer),
//     S(V) = clamp(T(clamp(V, 0, 1)), 0, 1)  (what the layer shows),
// as fmr_editor/engine/composite.py computes it on the CPU.  V, the mask colour and a are the layer's fields'
// evaluated window images (float, unclamped).  Outside the canvas: the checkerboard, as canvas.frag draws it.
// One pass reads every layer's images at the pixel: a pass a layer cost llvmpipe the pass itself, the position
// test and a read and write of the result each time.
//
// Which layers may show at the pixel comes with the run of cells it lies in (canvas.vert's v_code, two bits a
// layer k: 1 << 2k it may show, 2 << 2k its weight is surely 1 there, render/culling.py); a layer's images hold
// nothing where it may not show, nor its mask and alpha where its weight is 1, so they are not read there.
//
// The loader inserts after the #version line:
//     #define LAYERS n          layers in this pass
//     #define FIRST 0|1         1: the bottom layers, over the checkerboard: writes (out, 1);
//                               0: layers over those of earlier passes: writes (C, T), their composition over
//                               black and the share of what lies below that shows through (1 - m of each),
//                               blended ONE, SRC_ALPHA: out = C + T below
//     #define SAMPLERS ...      uniform sampler2D declarations of the images, masks and alphas read
//     #define BLEND_LAYERS ...  blend(k, image, mask, alpha, masked, translucent, transformed, texel); for
//                               k = 0 .. n - 1, in order (a layer without a mask or an alpha image passes its image
//                               in their place; translucent 0: opaque, 1: the alpha in its image's r, 2: in the
//                               layer's image's a (canvas.frag's ALPHA); one with the identity transform,
//                               transformed false)
// What a layer does not read or apply is compiled out (the arguments are constants): llvmpipe runs both sides of a
// branch.  A mask's image holds its luminance in each channel (the renderer's scalar field), so r is read.

SAMPLERS

uniform float u_mask_base[LAYERS];
uniform int u_inverted[LAYERS];
uniform float u_opacity[LAYERS];
uniform mat3 u_matrix[LAYERS];   // the colour transform T(v) = u_matrix v + u_offset
uniform vec3 u_offset[LAYERS];
uniform float u_negligible;      // a weight within it of 0 or 1 is 0 or 1 (engine.composite.NEGLIGIBLE_WEIGHT)
uniform dvec2 u_origin;          // as canvas.frag: the same test of which pixels lie on the canvas
uniform double u_step;
uniform float u_window_height;
uniform vec2 u_canvas;
uniform float u_checker;         // the checkerboard's square, window pixels

flat in int v_code;

out vec4 colour;

vec3 composed;
float through = 1.0;

void blend(int k, sampler2D image, sampler2D mask, sampler2D alpha, bool masked, int translucent, bool transformed,
           ivec2 texel) {
    if ((v_code & (1 << (2 * k))) == 0) {
        return;
    }
    vec4 image_value = texelFetch(image, texel, 0);
    vec3 shown = clamp(image_value.rgb, 0.0, 1.0);
    if (transformed) {
        shown = clamp(u_matrix[k] * shown + u_offset[k], 0.0, 1.0);
    }
    float m = 1.0;
    if ((v_code & (2 << (2 * k))) == 0) {
        float value = u_mask_base[k];
        if (masked) {
            value += texelFetch(mask, texel, 0).r;
        }
        if (u_inverted[k] != 0) {
            value = 1.0 - value;
        }
        float a = translucent == 0 ? 1.0
                  : clamp(translucent == 1 ? texelFetch(alpha, texel, 0).r : image_value.a, 0.0, 1.0);
        m = a * u_opacity[k] * clamp(value, 0.0, 1.0);
        m = m <= u_negligible ? 0.0 : m >= 1.0 - u_negligible ? 1.0 : m;
    }
    composed = shown * m + composed * (1.0 - m);
    through *= 1.0 - m;
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec2 window = vec2(gl_FragCoord.x, u_window_height - gl_FragCoord.y);
    dvec2 position = u_origin + dvec2(window) * u_step;
    if (position.x < 0.0 || position.y < 0.0 || position.x > double(u_canvas.x) || position.y > double(u_canvas.y)) {
        ivec2 square = ivec2(floor(window / u_checker));
        colour = FIRST != 0 ? vec4(vec3(((square.x + square.y) & 1) == 0 ? 0.8 : 0.6), 1.0) : vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
#if FIRST
    ivec2 square = ivec2(floor(window / u_checker));
    composed = vec3(((square.x + square.y) & 1) == 0 ? 0.8 : 0.6);
#else
    composed = vec3(0.0);
#endif
    BLEND_LAYERS
    colour = FIRST != 0 ? vec4(composed, 1.0) : vec4(composed, through);
}
