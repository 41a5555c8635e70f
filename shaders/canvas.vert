#version 410 core
// The canvas's geometry: one quad over the whole window, or (instanced) one quad per listed fine cell,
// grown by a window pixel on every side, so that re-evaluating changed cells touches only their pixels.
// The colour of every covered pixel comes from canvas.frag, which finds the pixel's cell itself.
// Window coordinates: pixels from the top-left corner, y down.

uniform int u_instanced;             // 0: one quad over the window; 1: one quad per cell of u_cell_list
uniform isamplerBuffer u_cell_list;  // flat fine-cell indices, row * cells per side + column
uniform int u_cells;                 // fine cells per side, 2^L
uniform vec2 u_cell_origin;          // window position of the document's origin
uniform float u_cell_window;         // a cell's side in window pixels
uniform vec2 u_window;               // window size in pixels

void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // a triangle strip of 4 vertices
    vec2 ndc = corner * 2.0 - 1.0;
    if (u_instanced != 0) {
        int cell = texelFetch(u_cell_list, gl_InstanceID).r;
        vec2 column_row = vec2(cell % u_cells, cell / u_cells);
        vec2 window = u_cell_origin + (column_row + corner) * u_cell_window + (corner * 2.0 - 1.0);
        ndc = vec2(window.x / u_window.x * 2.0 - 1.0, 1.0 - window.y / u_window.y * 2.0);
    }
    gl_Position = vec4(ndc, 0.0, 1.0);
}
