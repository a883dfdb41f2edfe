#version 460
// Decal pass, miss: nothing to do (every decal was handled by the any-hit shader).
#extension GL_EXT_ray_tracing : require
#include "decal_pass.glsl"

void main() {}
