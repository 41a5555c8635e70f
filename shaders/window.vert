#version 410 core
// One quad over the whole window (a triangle strip of 4 vertices from gl_VertexID), for per-pixel passes
// that read window-sized images (compose.frag).

void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
