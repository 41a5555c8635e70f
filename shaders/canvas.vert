#version 410 core
// The canvas's geometry: one quad over the whole window, or (instanced) one quad per listed fine cell,
// so that re-evaluating changed cells touches only their pixels, or one per listed run of cells along a row.
// Adjacent cells' and runs' quads share their corners exactly, so every pixel centre lies in exactly one of
// them (a delta pass adds to the image).
// The colour of every covered pixel comes from canvas.frag (or compose.frag); a cell's quad tells it the cell
// and the row of u_coeffs to read, the window quad and a run's leave both to the fragment (-1).
// Window coordinates: pixels from the top-left corner, y down.

uniform int u_instanced;             // 0: one quad over the window; 1: one quad per cell of u_cell_list;
                                     // 2: one quad per run of u_cell_list
uniform isamplerBuffer u_cell_list;  // flat fine-cell indices, row * cells per side + column; for runs, pairs:
                                     // the run's first cell, how many cells it holds
uniform int u_cells;                 // fine cells per side, 2^L
uniform vec2 u_cell_origin;          // window position of the document's origin
uniform float u_cell_window;         // a cell's side in window pixels
uniform vec2 u_window;               // window size in pixels
uniform int u_rows_by_instance;      // 1: cell i of the list reads coefficient row i (a delta pass), 0: its own

flat out int v_cell;                 // the quad's fine cell, -1 for the window quad
flat out int v_row;                  // the row of u_coeffs to read, -1: the pixel's cell

void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // a triangle strip of 4 vertices
    vec2 ndc = corner * 2.0 - 1.0;
    v_cell = -1;
    v_row = -1;
    if (u_instanced == 2) {
        int first = texelFetch(u_cell_list, 2 * gl_InstanceID).r;
        float count = float(texelFetch(u_cell_list, 2 * gl_InstanceID + 1).r);
        vec2 window = u_cell_origin + (vec2(first % u_cells, first / u_cells) + corner * vec2(count, 1.0)) * u_cell_window;
        ndc = vec2(window.x / u_window.x * 2.0 - 1.0, 1.0 - window.y / u_window.y * 2.0);
    } else if (u_instanced != 0) {
        int cell = texelFetch(u_cell_list, gl_InstanceID).r;
        v_cell = cell;
        v_row = u_rows_by_instance != 0 ? gl_InstanceID : cell;
        // (column + corner) is exact, so neighbours compute their shared corners identically
        vec2 window = u_cell_origin + (vec2(cell % u_cells, cell / u_cells) + corner) * u_cell_window;
        ndc = vec2(window.x / u_window.x * 2.0 - 1.0, 1.0 - window.y / u_window.y * 2.0);
    }
    gl_Position = vec4(ndc, 0.0, 1.0);
}
