#version 300 es
// Phantom geometry writes depth only: the colour writes are masked off while it is drawn, so the
// targets keep radiance 0 and alpha 0 where a real thing hides the object.
precision mediump float;
void main() {}
