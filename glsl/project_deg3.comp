// Stage 1, project, for scenes of SH degree 3 with the coefficients stored as 32-bit floats
// (see project_body.glsl).
#version 460
#define SH_DEGREE 3
#include "project_body.glsl"
