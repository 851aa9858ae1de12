// Stage 1, project, for scenes of SH degree 0 with the coefficients stored as 32-bit floats
// (see project_body.glsl).
#version 460
#define SH_DEGREE 0
#include "project_body.glsl"
