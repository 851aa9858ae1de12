//! Host struct layouts against what the compiled SPIR-V says, and spirv-val on every kernel.

use std::mem::offset_of;

use rara::gpu_types::{
    GpuClipParams, GpuCutoffRecord, GpuFrameParams, GpuGaussian, GpuProjectedSplat, GpuSortInfo,
};
use rara::shaders;

/// Member offsets of the struct type named `name` in a SPIR-V module (from OpName and
/// OpMemberDecorate ... Offset).
fn member_offsets(words: &[u32], name: &str) -> Vec<u32> {
    let mut ids = Vec::new();
    let mut offsets: Vec<(u32, u32, u32)> = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let (count, opcode) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        let ops = &words[i + 1..i + count];
        match opcode {
            5 => {
                // OpName: target id, then a nul-terminated string.
                let bytes: Vec<u8> = ops[1..].iter().flat_map(|w| w.to_le_bytes()).collect();
                let s = String::from_utf8_lossy(
                    &bytes[..bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len())],
                )
                .into_owned();
                if s == name {
                    ids.push(ops[0]);
                }
            }
            72 if ops[2] == 35 => offsets.push((ops[0], ops[1], ops[3])), // OpMemberDecorate Offset
            _ => {}
        }
        i += count.max(1);
    }
    let id = ids
        .into_iter()
        .find(|id| offsets.iter().any(|o| o.0 == *id))
        .unwrap_or_else(|| panic!("struct {name} not found"));
    let mut members: Vec<(u32, u32)> = offsets
        .iter()
        .filter(|o| o.0 == id)
        .map(|o| (o.1, o.2))
        .collect();
    members.sort();
    members.into_iter().map(|m| m.1).collect()
}

/// Asserts that struct `name` in `kernel` has its members at the host's `offsets`.
fn assert_layout(kernel: &[u32], name: &str, offsets: &[usize]) {
    let host: Vec<u32> = offsets.iter().map(|&o| o as u32).collect();
    assert_eq!(member_offsets(kernel, name), host, "{name}");
}

#[test]
fn gpu_struct_layouts_match_spirv() {
    let projected = [
        offset_of!(GpuProjectedSplat, uv),
        offset_of!(GpuProjectedSplat, opacity),
        offset_of!(GpuProjectedSplat, color0),
        offset_of!(GpuProjectedSplat, conic),
        offset_of!(GpuProjectedSplat, color1),
        offset_of!(GpuProjectedSplat, depth),
        offset_of!(GpuProjectedSplat, cutoff),
        offset_of!(GpuProjectedSplat, radius),
        offset_of!(GpuProjectedSplat, pad),
    ];
    assert_layout(shaders::PROJECT_DEG3, "ProjectedSplatWords", &projected);
    let gaussian = [
        offset_of!(GpuGaussian, pos_opacity),
        offset_of!(GpuGaussian, rot),
        offset_of!(GpuGaussian, scale),
    ];
    assert_layout(shaders::PROJECT_DEG3, "Gaussian", &gaussian);
    let frame = [
        offset_of!(GpuFrameParams, world_to_cam),
        offset_of!(GpuFrameParams, world_to_cam) + 16,
        offset_of!(GpuFrameParams, world_to_cam) + 32,
        offset_of!(GpuFrameParams, cam_pos),
        offset_of!(GpuFrameParams, focal),
        offset_of!(GpuFrameParams, background),
        offset_of!(GpuFrameParams, size),
        offset_of!(GpuFrameParams, scene),
    ];
    assert_layout(shaders::PROJECT_DEG3, "FrameParams", &frame);
    let sort = [
        offset_of!(GpuSortInfo, num_keys),
        offset_of!(GpuSortInfo, num_blocks),
        offset_of!(GpuSortInfo, hist_len),
        offset_of!(GpuSortInfo, block_keys),
        offset_of!(GpuSortInfo, block_args),
        offset_of!(GpuSortInfo, linear_args),
        offset_of!(GpuSortInfo, segmented),
        offset_of!(GpuSortInfo, seg_runs),
        offset_of!(GpuSortInfo, seg_pad),
        offset_of!(GpuSortInfo, pass_args),
        offset_of!(GpuSortInfo, local_args),
    ];
    assert_layout(shaders::SORT_PREPARE, "SortInfo", &sort);
    let clip = [
        offset_of!(GpuClipParams, config),
        offset_of!(GpuClipParams, band),
        offset_of!(GpuClipParams, sphere),
        offset_of!(GpuClipParams, planes),
    ];
    for kernel in [
        shaders::PROJECT_DEG3,
        shaders::RASTERIZE_MASS,
        shaders::RASTERIZE_STRIPS_LENGTH,
    ] {
        assert_layout(kernel, "ClipParams", &clip);
    }
    let cutoff = [
        offset_of!(GpuCutoffRecord, m0),
        offset_of!(GpuCutoffRecord, m1),
        offset_of!(GpuCutoffRecord, m2),
    ];
    assert_layout(shaders::CUTOFF_RECORDS, "CutoffRecord", &cutoff);
    let node = [
        offset_of!(rara::raytrace::bvh::GpuBvhNode, lo),
        offset_of!(rara::raytrace::bvh::GpuBvhNode, left),
        offset_of!(rara::raytrace::bvh::GpuBvhNode, hi),
        offset_of!(rara::raytrace::bvh::GpuBvhNode, right),
    ];
    for kernel in [shaders::BVH_BOUNDS, shaders::BVH_PROXIES] {
        assert_layout(kernel, "BvhNode", &node);
    }
}

#[test]
fn every_kernel_passes_spirv_val() {
    let Ok(out) = std::process::Command::new("spirv-val")
        .arg("--version")
        .output()
    else {
        eprintln!("spirv-val not installed (apt-get install spirv-tools): skipped");
        return;
    };
    assert!(out.status.success());
    let dir = std::env::temp_dir().join(format!("rara-spirv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let int64_forms = shaders::INT64_FORMS.iter().map(|(portable, int64)| {
        let name = shaders::ALL_KERNELS
            .iter()
            .find(|(_, w)| w == portable)
            .map_or("?", |(n, _)| n);
        (format!("{name}_int64"), *int64)
    });
    let every_form = shaders::ALL_KERNELS
        .iter()
        .map(|(name, words)| (name.to_string(), *words))
        .chain(int64_forms);
    for (name, words) in every_form {
        let path = dir.join(format!("{name}.spv"));
        std::fs::write(&path, bytemuck::cast_slice::<u32, u8>(words)).unwrap();
        let out = std::process::Command::new("spirv-val")
            .args(["--target-env", "vulkan1.2"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The capabilities a SPIR-V module declares (`OpCapability`, opcode 17).
fn capabilities(words: &[u32]) -> Vec<u32> {
    let mut caps = Vec::new();
    let mut at = 5; // past the header
    while at < words.len() {
        let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if opcode == 17 {
            caps.push(words[at + 1]);
        }
        at += count.max(1);
    }
    caps
}

/// The portable form of every kernel runs on a device without shaderInt64 (SwiftShader): it
/// declares no Int64 capability (11); the RARA_INT64 forms do, and exist for most kernels.
#[test]
fn portable_kernels_need_no_int64() {
    const INT64: u32 = 11;
    for (name, words) in shaders::ALL_KERNELS {
        assert!(
            !capabilities(words).contains(&INT64),
            "{name} declares the Int64 capability"
        );
    }
    for (portable, int64) in shaders::INT64_FORMS {
        assert!(capabilities(int64).contains(&INT64));
        assert_ne!(portable, int64);
    }
    assert!(
        shaders::INT64_FORMS.len() * 2 > shaders::ALL_KERNELS.len(),
        "{} of {} kernels have an int64 form",
        shaders::INT64_FORMS.len(),
        shaders::ALL_KERNELS.len()
    );
}
