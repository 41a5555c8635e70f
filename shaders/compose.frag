#version 410 core
// One layer of a layered picture drawn over what lies below (fmr_editor/render/picture_renderer.py):
//     out = m S(V) + (1 - m) below,  m = clamp(a, 0, 1) * opacity * clamp(M, 0, 1), 0 or 1 within u_negligible,
//     M = base + luma . mask colour (or 1 - that),  a = the alpha field's first channel (1 for an opaque layer),
//     S(V) = clamp(T(clamp(V, 0, 1)), 0, 1)  (what the layer shows),
// as fmr_editor/engine/composite.py computes it on the CPU.  V and the mask colour are the layer's and its mask's
// evaluated window images (float, unclamped); the blend unit does the mixing (SRC_ALPHA, ONE_MINUS_SRC_ALPHA),
// so this writes (S(V), m).  Outside the canvas it writes the checkerboard, as canvas.frag does (a blurred
// layer's image holds its reflection there).
// The loader (picture_renderer.py) inserts after the #version line, one program for each kind of pass (llvmpipe
// runs both sides of a branch, so what a pass does not read costs nothing only when it is compiled out):
//     #define PASS 0|1|2       0: the checkerboard under the layers, when the bottom one does not cover the
//                              canvas (where the picture is not opaque, it shows through: the colour over black
//                              plus (1 - coverage) checkerboard); 1: a layer; 2: the tint of a mask being edited,
//                              over the result (red, half strength where it hides all)
//     #define MASKED 0|1       1: read u_mask
//     #define TRANSLUCENT 0|1  1: read u_alpha

uniform sampler2D u_image;
uniform sampler2D u_mask;
uniform sampler2D u_alpha;
uniform float u_mask_base;
uniform int u_inverted;
uniform float u_opacity;
uniform float u_negligible;    // a weight within it of 0 or 1 is 0 or 1 (engine.composite.NEGLIGIBLE_WEIGHT)
uniform mat3 u_matrix;         // the colour transform T(v) = u_matrix v + u_offset
uniform vec3 u_offset;
uniform dvec2 u_origin;        // as canvas.frag: the same test of which pixels lie on the canvas
uniform double u_step;
uniform float u_window_height;
uniform vec2 u_canvas;
uniform float u_checker;       // the checkerboard's square, window pixels (as canvas.frag's outside the canvas)

const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);

out vec4 colour;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec2 window = vec2(gl_FragCoord.x, u_window_height - gl_FragCoord.y);
    ivec2 square = ivec2(floor(window / u_checker));
    vec4 checker = vec4(vec3(((square.x + square.y) & 1) == 0 ? 0.8 : 0.6), 1.0);
#if PASS == 0
    colour = checker;
#else
    dvec2 position = u_origin + dvec2(window) * u_step;
    bool outside = position.x < 0.0 || position.y < 0.0 || position.x > double(u_canvas.x)
                   || position.y > double(u_canvas.y);
    float m = u_mask_base;
#if MASKED
    m += dot(texelFetch(u_mask, texel, 0).rgb, LUMA);
#endif
    if (u_inverted != 0) {
        m = 1.0 - m;
    }
#if PASS == 2
    colour = outside ? checker : vec4(1.0, 0.1, 0.1, 0.5 * (1.0 - clamp(m, 0.0, 1.0)));
#else
    vec3 shown = clamp(u_matrix * clamp(texelFetch(u_image, texel, 0).rgb, 0.0, 1.0) + u_offset, 0.0, 1.0);
#if TRANSLUCENT
    float a = clamp(texelFetch(u_alpha, texel, 0).r, 0.0, 1.0);
#else
    float a = 1.0;
#endif
    float weight = a * u_opacity * clamp(m, 0.0, 1.0);
    colour = outside ? checker : vec4(shown, weight <= u_negligible ? 0.0 : weight >= 1.0 - u_negligible ? 1.0 : weight);
#endif
#endif
}
