#version 460
// Stage 1b, cutoff records (rara frames): one invocation per cutoff record, dispatched
// indirectly over the frame's count (linear_args.comp). Writes the record of the Gaussian that
// project listed under it (gaussian_cutoff_record in clip.glsl), the side record the later
// stages weight the cutoff splat by. Project lists the Gaussians instead of writing the
// records: a CPU driver runs a branch's stores, masked, in every SIMD vector, and a record is six
// 64-bit stores; here every lane has one.
#include "common.glsl"
#include "clip.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    Gaussians gaussians;
    U32s counters;
    U32s cutoff_gaussians;  // per cutoff record, its Gaussian (project)
    CutoffRecords cutoffs;  // out
} pc;

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint index = linear_index();
    if (index >= pc.counters.v[COUNTER_CUTOFF]) {
        return;
    }
    Gaussian g = load_gaussian(pc.gaussians, pc.cutoff_gaussians.v[index]);
    store_cutoff_record(pc.cutoffs, index, gaussian_cutoff_record(g, f.cam_pos.xyz));
}
