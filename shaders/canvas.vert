#version 410 core
// The canvas's geometry: one quad over the whole window, or (instanced) one quad per listed run of fine cells
// along a row, so that re-evaluating changed cells touches only their pixels.  Quads of adjacent runs share
// their corners exactly, so every pixel centre lies in exactly one of them (a delta pass adds to the image).
// The colour of every covered pixel comes from canvas.frag (or compose.frag); a run's quad tells it the cells
// it covers, so that a pixel on their edge reads one of them, never a neighbour outside the list (whose change
// tables, in a delta pass, may be old).
// With RUN_CODES defined (layers.frag), each listed run carries a third value, handed to the fragments as
// v_code (u_code for the window quad).
// Window coordinates: pixels from the top-left corner, y down.

#ifdef RUN_CODES
#define RUN_TEXELS 3
uniform int u_code;                  // the window quad's code
flat out int v_code;                 // the run's code
#else
#define RUN_TEXELS 2
#endif

uniform int u_instanced;             // 0: one quad over the window; 1: one quad per run of u_cell_list
uniform isamplerBuffer u_cell_list;  // per run: its first fine cell (row * cells per side + column), how
                                     // many cells it holds (and its code)
uniform int u_cells;                 // fine cells per side, 2^L
uniform vec2 u_cell_origin;          // window position of the document's origin
uniform float u_cell_window;         // a cell's side in window pixels
uniform vec2 u_window;               // window size in pixels

flat out ivec3 v_run;                // the quad's first and last column and its row; x = -1 for the window quad

void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // a triangle strip of 4 vertices
    vec2 ndc = corner * 2.0 - 1.0;
    v_run = ivec3(-1);
#ifdef RUN_CODES
    v_code = u_code;
#endif
    if (u_instanced != 0) {
        int first = texelFetch(u_cell_list, RUN_TEXELS * gl_InstanceID).r;
        int count = texelFetch(u_cell_list, RUN_TEXELS * gl_InstanceID + 1).r;
#ifdef RUN_CODES
        v_code = texelFetch(u_cell_list, RUN_TEXELS * gl_InstanceID + 2).r;
#endif
        ivec2 start = ivec2(first % u_cells, first / u_cells);
        v_run = ivec3(start.x, start.x + count - 1, start.y);
        // (column + corner) is exact, so neighbours compute their shared corners identically
        vec2 window = u_cell_origin + (vec2(start) + corner * vec2(count, 1.0)) * u_cell_window;
        ndc = vec2(window.x / u_window.x * 2.0 - 1.0, 1.0 - window.y / u_window.y * 2.0);
    }
    gl_Position = vec4(ndc, 0.0, 1.0);
}
