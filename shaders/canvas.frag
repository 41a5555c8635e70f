#version 410 core
// The FMR colour of a window pixel, as engine.rasterise computes it (samples=1, at the pixel centre):
//     far field (the cell's polynomial) + the 3x3 block's segments (closed forms) + the cell's near points.
// Outside the canvas: a checkerboard (or, for a field to be blurred, the picture reflected at the border).  A delta pass (u_delta = 1) evaluates the change of the colour from
// change tables bound in place of the data (no near points) and writes 0 outside the canvas, to be added.
//
// The loader (shader_source in fmr_editor/render/canvas_renderer.py) inserts after the #version line:
//     #define ORDER n             polynomial degree P
//     #define HARMONIC 0|1        1: coefficients are the complex local expansion K_l = L_l / 2pi,
//                                 u = Re sum_l K_l (xi + i eta)^l, a texel (rgb) for Re K_l, one for Im K_l;
//                                 0: the full tensor c[i][j] of xi^i eta^j, a texel (rgb) per (i, j)
//     #define COEFF_TEXELS m      RGBA texels per cell of u_coeffs
//     #define ALPHA 0|1           1: a colour field with its layer's alpha field in a fourth channel (packing.py):
//                                 coefficients (rgb, alpha), segments (E, E alpha), (C, C alpha), written to rgba
//     #define SEGMENTS 0|1        0: no near segments anywhere (a field of diffusion points alone): their loop is
//                                 compiled out
//     #define SCALAR 0|1          1: a scalar field (a mask's luminance, an alpha's or a blur's first channel),
//                                 its tables four values a texel (packing.py), its value written to r, g and b:
//                                 harmonic, per l Re K_l, Im K_l; tensor, each row c[i][0..P] padded to whole
//                                 texels
// Data (texture buffers, layouts written by fmr_editor/render/packing.py):
//     u_coeffs           RGBA32F, COEFF_TEXELS texels per cell, cells row-major
//     u_segment_start    R32I, CSR offsets of each cell's list of near segments (cells^2 + 1)
//     u_segments         RGBA32F, 3 texels per entry: (p, q relative to the listing cell's centre),
//                        (E rgb, length), (C rgb, 0); document pixels.  A cell lists the segments of
//                        its 3x3 block.
//     u_point_start      R32I, CSR offsets of each cell's near points (cells^2 + 1)
//     u_point_members    R32I, indices into u_points
//     u_points           RGBA32F, 2 texels per near point: (x, y, 1 / r^2, 0), (weight rgb, 0)
// Precision: the window-to-document map and the cell lookup are in double, everything else in float;
// segment integrals work in coordinates relative to the pixel's cell so nothing large cancels.

uniform dvec2 u_origin;        // document position of the window's top-left corner
uniform double u_step;         // document pixels per window pixel
uniform float u_window_height;
uniform vec2 u_canvas;         // canvas width, height in document pixels
uniform int u_cells;           // fine cells per side, 2^L
uniform double u_cell_size;    // document pixels
uniform float u_checker;       // checkerboard square, window pixels
uniform int u_delta;           // 1: a delta pass
uniform int u_reflect;         // 1: beyond the canvas, the picture reflected at its border (to be blurred)

uniform samplerBuffer u_coeffs;
uniform isamplerBuffer u_segment_start;
uniform samplerBuffer u_segments;
uniform isamplerBuffer u_point_start;
uniform isamplerBuffer u_point_members;
uniform samplerBuffer u_points;

flat in ivec3 v_run;           // the cells of the quad being drawn: first and last column, row; x = -1: any

out vec4 colour;

const float INV_TWO_PI = 0.15915494309189535;
const float INV_FOUR_PI = 0.07957747154594767;

#if SCALAR
#define VALUE float
#define SEGMENT_TEXELS 2
#define POINT_TEXELS 1

// Four terms a texel, zeros after the last (they add nothing to Horner's sums), each texel read once and its
// components in a fixed order (an array indexed by the term cost llvmpipe three times the whole pass)
float far_field(int row, vec2 xi) {
    int base = row * COEFF_TEXELS;
#if HARMONIC
    // Horner in z = xi + i eta; texel t holds Re, Im of K_2t, then of K_2t+1
    vec2 sum = vec2(0.0);
    for (int t = COEFF_TEXELS - 1; t >= 0; --t) {
        vec4 c = texelFetch(u_coeffs, base + t);
        sum = vec2(sum.x * xi.x - sum.y * xi.y, sum.x * xi.y + sum.y * xi.x) + c.zw;
        sum = vec2(sum.x * xi.x - sum.y * xi.y, sum.x * xi.y + sum.y * xi.x) + c.xy;
    }
    return sum.x;
#else
    // Horner in eta along each row i (ROW_TEXELS texels: c[i][0..3], c[i][4..7], ...), then in xi
    const int ROW_TEXELS = (ORDER + 4) / 4;
    float value = 0.0;
    for (int i = ORDER; i >= 0; --i) {
        float along = 0.0;
        for (int t = ROW_TEXELS - 1; t >= 0; --t) {
            vec4 c = texelFetch(u_coeffs, base + i * ROW_TEXELS + t);
            along = (((along * xi.y + c.w) * xi.y + c.z) * xi.y + c.y) * xi.y + c.x;
        }
        value = value * xi.x + along;
    }
    return value;
#endif
}
#else
#if ALPHA
#define VALUE vec4
#define CHANNELS rgba
#else
#define VALUE vec3
#define CHANNELS rgb
#endif
#define SEGMENT_TEXELS 3
#define POINT_TEXELS 2

VALUE coefficient(int texel) {
    return texelFetch(u_coeffs, texel).CHANNELS;
}

VALUE far_field(int row, vec2 xi) {
    int base = row * COEFF_TEXELS;
#if HARMONIC
    // Horner in z = xi + i eta, every channel at once; texels Re K_l, Im K_l
    VALUE re = coefficient(base + 2 * ORDER);
    VALUE im = coefficient(base + 2 * ORDER + 1);
    for (int l = ORDER - 1; l >= 0; --l) {
        VALUE next = re * xi.x - im * xi.y + coefficient(base + 2 * l);
        im = re * xi.y + im * xi.x + coefficient(base + 2 * l + 1);
        re = next;
    }
    return re;
#else
    // Horner in eta along each row i, then in xi; texel i * (ORDER + 1) + j holds c[i][j]
    VALUE value = VALUE(0.0);
    for (int i = ORDER; i >= 0; --i) {
        int first = base + i * (ORDER + 1);
        VALUE row = coefficient(first + ORDER);
        for (int j = ORDER - 1; j >= 0; --j) {
            row = row * xi.y + coefficient(first + j);
        }
        value = value * xi.x + row;
    }
    return value;
#endif
}
#endif

// E S - C D of the segments near the pixel: the list of its cell (the cell's 3x3 block), each segment's
// end points p, q relative to the cell's centre, so p - x and q - x stay small.
VALUE near_segments(int cell, vec2 local) {
    VALUE sum = VALUE(0.0);
    int end = texelFetch(u_segment_start, cell + 1).r;
    for (int k = texelFetch(u_segment_start, cell).r; k < end; ++k) {
        vec4 ends = texelFetch(u_segments, SEGMENT_TEXELS * k);
        vec4 values = texelFetch(u_segments, SEGMENT_TEXELS * k + 1);
#if SCALAR
        float flux = values.x, jump = values.y, h = values.z;
#elif ALPHA
        vec4 flux = values, jump = texelFetch(u_segments, 3 * k + 2);
        float h = length(ends.zw - ends.xy);
#else
        vec3 flux = values.rgb, jump = texelFetch(u_segments, 3 * k + 2).rgb;
        float h = values.w;
#endif
        vec2 t = (ends.zw - ends.xy) / h;
        // p - x and q - x from the stored end points (not p + h t), so a pixel centre exactly on a segment
        // gets an exactly zero cross product, and the principal value, as on the CPU
        vec2 v0 = ends.xy - local;
        vec2 v1 = ends.zw - local;
        float a = -dot(v0, t);
        float b = abs(v0.x * t.y - v0.y * t.x);
        float cross_ = v0.x * v1.y - v0.y * v1.x;
        float dot_ = dot(v0, v1);
        // the angle subtended; 0 (the principal value) on the segment itself and on its line outside it
        float angle = (cross_ != 0.0 || dot_ > 0.0) ? atan(cross_, dot_) : 0.0;
        float log_p = log(max(dot(v0, v0), 1e-30));
        float log_q = log(max(dot(v1, v1), 1e-30));
        float single = ((h - a) * log_q + a * log_p - 2.0 * h + 2.0 * b * abs(angle)) * INV_FOUR_PI;
        sum += flux * single - jump * (angle * INV_TWO_PI);
    }
    return sum;
}

VALUE near_points(int cell, dvec2 position) {
    VALUE sum = VALUE(0.0);
    int end = texelFetch(u_point_start, cell + 1).r;
    for (int e = texelFetch(u_point_start, cell).r; e < end; ++e) {
        int p = texelFetch(u_point_members, e).r;
        vec4 centre = texelFetch(u_points, POINT_TEXELS * p);
#if SCALAR
        float weight = centre.w;
#else
        VALUE weight = texelFetch(u_points, 2 * p + 1).CHANNELS;
#endif
        vec2 d = vec2(position - dvec2(centre.xy));
        sum += weight * exp(-dot(d, d) * centre.z);
    }
    return sum;
}

void main() {
    vec2 window = vec2(gl_FragCoord.x, u_window_height - gl_FragCoord.y);
    dvec2 position = u_origin + dvec2(window) * u_step;
    if (u_reflect != 0) {
        dvec2 size = dvec2(u_canvas);
        position = size - abs(mod(position, 2.0 * size) - size);
    }
    if (position.x < 0.0 || position.y < 0.0 || position.x > double(u_canvas.x) || position.y > double(u_canvas.y)) {
        ivec2 square = ivec2(floor(window / u_checker));
        colour = u_delta != 0 ? vec4(0.0) : vec4(vec3(((square.x + square.y) & 1) == 0 ? 0.8 : 0.6), 1.0);
        return;
    }
    ivec2 cell = clamp(ivec2(floor(position / u_cell_size)), ivec2(0), ivec2(u_cells - 1));
    if (v_run.x >= 0) {  // a pixel on the quad's edge reads its cells, not a neighbour's
        cell = ivec2(clamp(cell.x, v_run.x, v_run.y), v_run.z);
    }
    float size = float(u_cell_size);
    vec2 local = vec2(position - (dvec2(cell) + 0.5) * u_cell_size);  // from the cell's centre
    int flat_cell = cell.y * u_cells + cell.x;
    VALUE value = far_field(flat_cell, local / size);
#if SEGMENTS
    value += near_segments(flat_cell, local);
#endif
#if !HARMONIC
    if (u_delta == 0) {  // (a field in harmonic form has no points: their loop, even empty, costs a tenth)
        value += near_points(flat_cell, position);
    }
#endif
#if ALPHA
    colour = value;
#else
    colour = vec4(vec3(value), u_delta != 0 ? 0.0 : 1.0);
#endif
}
