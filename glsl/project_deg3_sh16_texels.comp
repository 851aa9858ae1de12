// Stage 1, project, for scenes of SH degree 3 with the coefficients stored as half floats, two to
// a uint (ShPrecision::F16), reading the Gaussians and coefficients through the frame's texel
// views (CPU drivers; see project_body.glsl).
#version 460
#define SH_DEGREE 3
#define SH_HALF 1
#define SCENE_TEXELS
#include "project_body.glsl"
