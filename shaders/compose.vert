// compose.vert: the full-screen triangle that drives shaders/compose.frag, one fragment per film pixel.
//
// No vertex buffers: the three corners come from gl_VertexID, so the caller only binds an
// empty VAO (the core profile requires one) and draws 3 vertices. The triangle overshoots the
// viewport and is clipped to exactly the [-1,1] square; compose.frag reads gl_FragCoord, so
// no texture coordinates are passed on.
#version 330 core

void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)); // (0,0) (2,0) (0,2)
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
