// Stage 1, project, with SH coefficients stored as 32-bit floats (see project_body.glsl).
#version 460
#include "project_body.glsl"
