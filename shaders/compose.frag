#version 410 core
// The passes of a layered picture besides its layers' (shaders/layers.frag, fmr_editor/render/picture_renderer.py):
// the checkerboard beyond the lattice the layers' passes draw, and the tint of a mask being edited, over the
// result: red, half strength where the mask hides all (M = base + luma . mask colour, or 1 - that); outside
// the canvas the checkerboard, as canvas.frag draws it.
// The loader inserts after the #version line:
//     #define TINT 0|1     0: the checkerboard; 1: the tint
//     #define MASKED 0|1   1: read u_mask (a tint's mask with items)

uniform sampler2D u_mask;
uniform float u_mask_base;
uniform int u_inverted;
uniform dvec2 u_origin;        // as canvas.frag: the same test of which pixels lie on the canvas
uniform double u_step;
uniform float u_window_height;
uniform vec2 u_canvas;
uniform float u_checker;       // the checkerboard's square, window pixels (as canvas.frag's outside the canvas)

out vec4 colour;

void main() {
    vec2 window = vec2(gl_FragCoord.x, u_window_height - gl_FragCoord.y);
    ivec2 square = ivec2(floor(window / u_checker));
    vec4 checker = vec4(vec3(((square.x + square.y) & 1) == 0 ? 0.8 : 0.6), 1.0);
#if TINT
    dvec2 position = u_origin + dvec2(window) * u_step;
    bool outside = position.x < 0.0 || position.y < 0.0 || position.x > double(u_canvas.x)
                   || position.y > double(u_canvas.y);
    float m = u_mask_base;
#if MASKED
    m += texelFetch(u_mask, ivec2(gl_FragCoord.xy), 0).r;  // the luminance (the mask's scalar field)
#endif
    if (u_inverted != 0) {
        m = 1.0 - m;
    }
    colour = outside ? checker : vec4(1.0, 0.1, 0.1, 0.5 * (1.0 - clamp(m, 0.0, 1.0)));
#else
    colour = checker;
#endif
}
