#version 410 core
// Instanced rectangles of the target framebuffer: instance i covers u_rects' texel u_first + i, (x0, y0, x1, y1) in GL
// pixels of the target (y up), so that a pass touches only the pixels it must (fmr_editor/render/blur_filter.py).

uniform samplerBuffer u_rects;
uniform int u_first;           // the first rectangle of this pass in u_rects
uniform vec2 u_target;         // the target's size in pixels

void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // a triangle strip of 4 vertices
    vec4 rect = texelFetch(u_rects, u_first + gl_InstanceID);
    gl_Position = vec4(mix(rect.xy, rect.zw, corner) / u_target * 2.0 - 1.0, 0.0, 1.0);
}
