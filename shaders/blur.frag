#version 410 core
// fmr_editor/engine/blur.py's blurred_within on the GPU, a pass at a time (fmr_editor/render/blur_filter.py).
// One source, three programs (the loader inserts #define MODE m, and MAX_RADIUS n = engine.blur.MAX_RADIUS;
// one program for all three ran four times slower under llvmpipe):
//     MODE 0  halve:  the means of u_source's 2 x 2 blocks (the next octave)
//     MODE 1  filter: u_source convolved along u_axis with u_weights (engine.blur.pixel_kernel), the edge's
//                     texel standing beyond the edge
//     MODE 2  blend:  at the window pixels of deviation s in (u_low, u_high] (a bracket of the ladder; s the
//                     blur field u_sigma times u_scale, clamped to [0, u_largest]), levels k - 1 (u_lower) and
//                     k (u_upper) interpolated bilinearly from their octaves, then mixed as lower + t (upper -
//                     lower), t = (s - u_low) / (u_high - u_low) (bracket 0, the picture as it is, reads it
//                     for both)
// Pixels are GL's (y up): the padded image holds u_extra.x columns left of the window and u_extra.y rows below
// it, its height a multiple of the deepest octave's pixel, so its octaves' pixels line up with the window's
// counted from the top as on the CPU.

out vec4 colour;

#if MODE == 0
uniform sampler2D u_source;

void main() {
    ivec2 a = 2 * ivec2(gl_FragCoord.xy);
    colour = ((texelFetch(u_source, a, 0) + texelFetch(u_source, a + ivec2(1, 0), 0))
              + (texelFetch(u_source, a + ivec2(0, 1), 0) + texelFetch(u_source, a + ivec2(1, 1), 0))) * 0.25;
}

#elif MODE == 1
uniform sampler2D u_source;
uniform int u_axis;            // 0: along x, 1: along y
uniform int u_radius;
uniform float u_weights[2 * MAX_RADIUS + 1];

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    ivec2 step = u_axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
    ivec2 last = textureSize(u_source, 0) - 1;
    vec4 sum = vec4(0.0);
    for (int i = -u_radius; i <= u_radius; ++i) {
        sum += u_weights[i + u_radius] * texelFetch(u_source, clamp(texel + i * step, ivec2(0), last), 0);
    }
    colour = sum;
}

#else
uniform sampler2D u_lower;
uniform sampler2D u_upper;
uniform int u_lower_octave;
uniform int u_upper_octave;
uniform sampler2D u_sigma;
uniform float u_scale;
uniform float u_largest;
uniform float u_low;
uniform float u_high;
uniform ivec2 u_extra;

vec4 at(sampler2D image, ivec2 texel) {
    return texelFetch(image, clamp(texel, ivec2(0), textureSize(image, 0) - 1), 0);
}

// ``image``, the padded picture halved ``d`` times, at the centre of the padded picture's pixel ``fine``
vec4 sampled(sampler2D image, int d, ivec2 fine) {
    if (d == 0) {
        return texelFetch(image, fine, 0);
    }
    vec2 u = (vec2(fine) + 0.5) / float(1 << d) - 0.5;
    ivec2 low = ivec2(floor(u));
    vec2 t = u - vec2(low);
    vec4 bottom = mix(at(image, low), at(image, low + ivec2(1, 0)), t.x);
    vec4 top = mix(at(image, low + ivec2(0, 1)), at(image, low + ivec2(1, 1)), t.x);
    return mix(bottom, top, t.y);
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float s = clamp(texelFetch(u_sigma, texel, 0).r * u_scale, 0.0, u_largest);
    if (s <= u_low || s > u_high) {
        discard;
    }
    ivec2 fine = texel + u_extra;
    vec4 lower = sampled(u_lower, u_lower_octave, fine);
    colour = lower + (s - u_low) / (u_high - u_low) * (sampled(u_upper, u_upper_octave, fine) - lower);
}
#endif
