// Stage 1, project, for scenes of SH degree 1 with the coefficients stored as 32-bit floats,
// reading the Gaussians and coefficients through the frame's texel views (CPU drivers; see
// project_body.glsl).
#version 460
#define SH_DEGREE 1
#define SCENE_TEXELS
#include "project_body.glsl"
