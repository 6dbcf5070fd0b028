#version 300 es
// Phantom geometry (appliance/render/phantom.hpp). The table writes depth only (colour writes
// masked). A proxy also marks its pixels with alpha -1 in the normal target (the only draw buffer
// left on while it is drawn), so the composite does not put the table's shadow on a real thing
// that stands in front of the table; the object, drawn after, overwrites the mark where it is in
// front of the proxy.
precision mediump float;
layout(location = 1) out vec4 o_mark;
void main() { o_mark = vec4(0.0, 0.0, 0.0, -1.0); }
