//! Mixed scenes on the GPU (SPEC section 8, issue 33): per pixel a ray tree, walked one ray
//! per generation. A generation is `glsl/mixed_spawn.comp` (take in the last ray's result,
//! shade its mesh hit, pop the next ray, find its mesh hit) then the ray tracer's MIXED kernels
//! ([`super::tracer`]) over every pixel's ray, compositing its Gaussians up to the mesh. The
//! host runs generations until no pixel has a ray left (one wait per generation: this path is
//! headless, [`MixedTracer::render`]). The Gaussians' BVH is built once per frame, in the
//! first generation; the triangles' BVH is built on the host (obvhs) when the scene is loaded
//! ([`crate::mixed::triangles::MeshBvh`]). CPU twin: [`crate::reference::mixed`].

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::tracer::{MixedRays, RayTracer, TraceBuffers, MAX_TRACE_ROUNDS, TRACE_PARAMS_BYTES};
use crate::camera::Camera;
use crate::constants::{
    MIXED_COUNTER_CUT, MIXED_COUNTER_LIVE, MIXED_COUNTER_LONG_WALKS, MIXED_COUNTER_OVERFLOW,
    MIXED_COUNTER_PRIMARY, MIXED_COUNTER_SECONDARY, MIXED_COUNTER_SHADOW, MIXED_COUNTER_WORDS,
    MIXED_MAX_LIGHTS, MIXED_MESH_VISITS_MAX, MIXED_STACK,
};
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuClipParams;
use crate::mixed::material::{gpu_materials, GpuMaterial};
use crate::mixed::triangles::{GpuShading, GpuTriangle};
use crate::mixed::{Light, MixedScene};
use crate::options::RayTraceOptions;
use crate::precision::ShPrecision;
use crate::shaders;
use crate::stages::linear_grid;
use crate::timing::PassTimer;
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

/// Rounds a generation's trace records at first; the host records more (twice as many each
/// time) while rays are live. A round with no live ray still costs its two dispatches, and
/// most generations need one or two rounds (glass_plant at 320x240: 64 rounds at first took
/// about 50 ms per generation with a single live ray, docs/PERFORMANCE.md).
pub const FIRST_GENERATION_ROUNDS: u32 = 4;

/// Generations a frame may take at most (a pixel's tree: its rays and its shadow rays).
pub const MAX_GENERATIONS: u32 = 512;

/// `MixedParams` of `glsl/mixed_common.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuMixedParams {
    counts: [u32; 4],
    ambient: [f32; 4],
    background: [f32; 4],
    objects: [u32; 4],
    light_at: [[f32; 4]; MIXED_MAX_LIGHTS as usize],
    light_intensity: [[f32; 4]; MIXED_MAX_LIGHTS as usize],
    refs: [u32; 4],
    refs2: [u32; 4],
    occluders: [u32; 4],
    occluder_counts: [u32; 4],
    lists: [u32; 4],
    surfaces: [u32; 4],
    texels: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SpawnPush {
    mixed: u64,
    camera: u64,
    state: u64,
    acc: u64,
    cur: u64,
    cur_hit: u64,
    cur_tri: u64,
    stack: u64,
    sp: u64,
    counters: u64,
    list_in: u64,
    list_out: u64,
    batch_counts: u64,
    generation: u32,
    pixels: u32,
    count_in: u32,
    pad: u32,
}

fn lo_hi(a: u64) -> [u32; 2] {
    [a as u32, (a >> 32) as u32]
}

/// A mixed scene on the device: the merged Gaussians, the triangles and their BVH, the splat
/// objects' clips, and the scene's parameters (without the per-frame addresses).
pub struct GpuMixedScene {
    /// The Gaussians of every splat object.
    pub gaussians: GpuScene,
    triangles: Buffer,
    nodes: Buffer,
    occluder_triangles: Buffer,
    occluder_nodes: Buffer,
    clips: Buffer,
    /// Per splat object its first Gaussian (`object_of` in `glsl/mixed_common.glsl`).
    object_firsts: Buffer,
    /// Per triangle (in `triangles`' order) its normals, UVs and material.
    shading: Buffer,
    /// The materials ([`GpuMaterial`]).
    materials: Buffer,
    /// Every texture's texels, RGBA8 words.
    texels: Buffer,
    params: GpuMixedParams,
    /// The first object's clip (the tracer's `clip`, for its validation and upload).
    clip0: crate::clip::Clip,
}

impl GpuMixedScene {
    /// Uploads `scene` (validated first), the coefficients at `precision`.
    pub fn new(ctx: &Context, scene: &MixedScene, precision: ShPrecision) -> Result<Self> {
        scene.validate()?;
        let gaussians = GpuScene::with_sh_precision(ctx, &scene.gaussians, precision)?;
        // (A buffer is never empty: a scene without meshes gets one unused entry.)
        fn or_one<T: Default>(mut v: Vec<T>) -> Vec<T> {
            if v.is_empty() {
                v.push(T::default());
            }
            v
        }
        let gpu_triangles = |bvh: &crate::mixed::triangles::MeshBvh| -> Vec<GpuTriangle> {
            or_one(bvh.triangles.iter().map(|t| t.gpu()).collect())
        };
        let shading: Vec<GpuShading> = or_one(
            scene
                .meshes
                .triangles
                .iter()
                .map(|t| t.gpu_shading())
                .collect(),
        );
        let (materials, texels) = gpu_materials(&scene.materials, &scene.textures);
        let shading = Buffer::from_slice(ctx, "mixed triangle shading", &shading)?;
        let materials =
            Buffer::from_slice(ctx, "mixed materials", &or_one::<GpuMaterial>(materials))?;
        let texels = Buffer::from_slice(ctx, "mixed texels", &or_one::<u32>(texels))?;
        let node_data = |bvh: &crate::mixed::triangles::MeshBvh| {
            if bvh.nodes.is_empty() {
                vec![Default::default()]
            } else {
                bvh.nodes.clone()
            }
        };
        let triangles = Buffer::from_slice(ctx, "mixed triangles", &gpu_triangles(&scene.meshes))?;
        let nodes = Buffer::from_slice(ctx, "mixed mesh nodes", &node_data(&scene.meshes))?;
        let occluder_triangles = Buffer::from_slice(
            ctx,
            "mixed occluder triangles",
            &gpu_triangles(&scene.occluders),
        )?;
        let occluder_nodes =
            Buffer::from_slice(ctx, "mixed occluder nodes", &node_data(&scene.occluders))?;
        let clip_data: Vec<GpuClipParams> = scene.objects.iter().map(|o| o.clip.to_gpu()).collect();
        let clips = Buffer::from_slice(ctx, "mixed object clips", &clip_data)?;
        let mut params = GpuMixedParams::zeroed();
        params.counts = [
            scene.meshes.triangles.len() as u32,
            scene.meshes.nodes.len() as u32,
            scene.lights.len() as u32,
            scene.objects.len() as u32,
        ];
        params.ambient = [
            scene.ambient.x,
            scene.ambient.y,
            scene.ambient.z,
            scene.shadow_strength,
        ];
        params.background = [
            scene.background.x,
            scene.background.y,
            scene.background.z,
            scene.max_depth as f32,
        ];
        let firsts: Vec<u32> = scene.objects.iter().map(|o| o.first).collect();
        let object_firsts = Buffer::from_slice(ctx, "mixed object firsts", &firsts)?;
        let [a, b] = lo_hi(object_firsts.address);
        params.objects = [a, b, 0, 0];
        let [a, b] = lo_hi(shading.address);
        let [c, d] = lo_hi(materials.address);
        params.surfaces = [a, b, c, d];
        let [a, b] = lo_hi(texels.address);
        params.texels = [a, b, scene.materials.len() as u32, 0];
        for (k, l) in scene.lights.iter().enumerate() {
            let (at, i) = match *l {
                Light::Point {
                    position,
                    intensity,
                } => ([position.x, position.y, position.z, 0.0], intensity),
                Light::Directional {
                    direction,
                    intensity,
                } => ([direction.x, direction.y, direction.z, 1.0], intensity),
            };
            params.light_at[k] = at;
            params.light_intensity[k] = [i.x, i.y, i.z, 0.0];
        }
        let [a, b] = lo_hi(triangles.address);
        let [c, d] = lo_hi(nodes.address);
        params.refs = [a, b, c, d];
        let [a, b] = lo_hi(occluder_triangles.address);
        let [c, d] = lo_hi(occluder_nodes.address);
        params.occluders = [a, b, c, d];
        params.occluder_counts = [
            scene.occluders.triangles.len() as u32,
            scene.occluders.nodes.len() as u32,
            0,
            0,
        ];
        Ok(GpuMixedScene {
            gaussians,
            triangles,
            nodes,
            occluder_triangles,
            occluder_nodes,
            clips,
            object_firsts,
            shading,
            materials,
            texels,
            params,
            clip0: scene.objects[0].clip.clone(),
        })
    }

    /// Splat objects.
    pub fn objects(&self) -> usize {
        self.params.counts[3] as usize
    }

    /// Replaces the splat objects' clips (one per object, in the world), as a sweep moves a
    /// plane; the Gaussians and meshes stay.
    pub fn set_clips(&mut self, clips: &[crate::clip::Clip]) -> Result<()> {
        if clips.len() != self.params.counts[3] as usize {
            return Err(Error::InvalidInput(format!(
                "{} clips for {} splat objects",
                clips.len(),
                self.params.counts[3]
            )));
        }
        for c in clips {
            c.validate()?;
        }
        let data: Vec<GpuClipParams> = clips.iter().map(|c| c.to_gpu()).collect();
        self.clips.upload(bytemuck::cast_slice(&data))?;
        self.clip0 = clips[0].clone();
        Ok(())
    }

    /// Device bytes of the meshes (their triangles, shading data, BVHs, materials and
    /// textures), the clips and the objects' first Gaussians (the Gaussians' are
    /// [`GpuScene`]'s).
    pub fn mesh_bytes(&self) -> u64 {
        self.triangles.size
            + self.shading.size
            + self.materials.size
            + self.texels.size
            + self.nodes.size
            + self.occluder_triangles.size
            + self.occluder_nodes.size
            + self.clips.size
            + self.object_firsts.size
    }
}

/// What a mixed frame did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MixedFrameStats {
    /// Camera rays.
    pub primary: u64,
    /// Reflected and refracted rays.
    pub secondary: u64,
    /// Shadow rays (those a mesh blocks included).
    pub shadow: u64,
    /// Branches the depth or weight limit cut.
    pub cut: u64,
    /// Generations the frame took.
    pub generations: u32,
    /// Per pass, its GPU milliseconds summed over the generations.
    pub passes: Vec<(&'static str, f64)>,
}

/// The per-pixel buffers of the ray tree.
struct TreeBuffers {
    camera: Buffer,
    params: Buffer,
    rays: Buffer,
    acc: Buffer,
    cur: Buffer,
    cur_hit: Buffer,
    cur_tri: Buffer,
    stack: Buffer,
    sp: Buffer,
    /// Two lists of pixels, each generation's rays and the next's (`mixed_spawn.comp`).
    lists: Buffer,
    /// Per tracer batch, the list of its rays of this generation (indices in the batch).
    trace_lists: Buffer,
    /// Per tracer batch, the rays in its list.
    batch_counts: Buffer,
    counters: Buffer,
    readback: Buffer,
}

impl TreeBuffers {
    fn new(ctx: &Context, pixels: u64, batches: u32) -> Result<Self> {
        let gpu = MemoryLocation::GpuOnly;
        let counters = MIXED_COUNTER_WORDS as u64 * 4;
        Ok(TreeBuffers {
            camera: Buffer::new(ctx, "mixed camera", TRACE_PARAMS_BYTES, gpu)?,
            params: Buffer::new(
                ctx,
                "mixed params",
                std::mem::size_of::<GpuMixedParams>() as u64,
                gpu,
            )?,
            rays: Buffer::new(ctx, "mixed rays", pixels * 64, gpu)?,
            acc: Buffer::new(ctx, "mixed colours", pixels * 16, gpu)?,
            cur: Buffer::new(ctx, "mixed current rays", pixels * 48, gpu)?,
            cur_hit: Buffer::new(ctx, "mixed mesh hits", pixels * 16, gpu)?,
            cur_tri: Buffer::new(ctx, "mixed hit triangles", pixels * 4, gpu)?,
            stack: Buffer::new(
                ctx,
                "mixed ray stacks",
                pixels * 48 * MIXED_STACK as u64,
                gpu,
            )?,
            sp: Buffer::new(ctx, "mixed stack sizes", pixels * 4, gpu)?,
            lists: Buffer::new(ctx, "mixed pixel lists", 2 * pixels * 4, gpu)?,
            trace_lists: Buffer::new(ctx, "mixed traced rays", pixels * 4, gpu)?,
            batch_counts: Buffer::new(ctx, "mixed traced rays per batch", batches as u64 * 4, gpu)?,
            counters: Buffer::new(ctx, "mixed counters", counters, gpu)?,
            readback: Buffer::new(
                ctx,
                "mixed counters (host)",
                counters + batches as u64 * 4,
                MemoryLocation::GpuToCpu,
            )?,
        })
    }

    fn counter(&self, slot: u32) -> u32 {
        let at = slot as usize * 4;
        bytemuck::pod_read_unaligned(&self.readback.mapped()[at..at + 4])
    }

    /// The rays tracer batch `b` traces this generation.
    fn batch_count(&self, b: u32) -> u32 {
        self.counter(MIXED_COUNTER_WORDS + b)
    }
}

/// The mixed scenes' kernels: the ray tree's and a ray tracer (k = 64 through texel views on
/// CPU drivers, 16 by address on GPUs: the pairings the MIXED kernels are built for).
pub struct MixedTracer {
    tracer: RayTracer,
    spawn: ComputePipeline,
    ctx: Context,
}

impl MixedTracer {
    /// The kernels for `ctx`'s device.
    pub fn new(ctx: &Context) -> Result<Self> {
        let cpu = crate::stages::rasterize::RasterLayout::for_device(ctx)
            == crate::stages::rasterize::RasterLayout::Strips;
        Ok(MixedTracer {
            tracer: RayTracer::with_k(ctx, if cpu { 64 } else { 16 })?,
            spawn: ComputePipeline::new::<SpawnPush>(ctx, c"mixed_spawn", shaders::MIXED_SPAWN)?,
            ctx: ctx.clone(),
        })
    }

    /// Builds the BVH of `scene`'s Gaussians once, on the host, for a scene that does not
    /// move ([`super::still_bvh`]); every generation's rays then walk it. The same image.
    pub fn build_still_bvh(
        &self,
        scene: &mut GpuMixedScene,
    ) -> Result<super::still_bvh::StillBvhStats> {
        let q = RayTraceOptions::default().q as f32;
        self.tracer
            .build_still_bvh(&self.ctx, &mut scene.gaussians, q)
    }

    /// The tracer's k-buffer size.
    pub fn k(&self) -> u32 {
        self.tracer.k()
    }

    /// Renders `scene` from `camera` with the tracer options `options`, headless: generation
    /// after generation until every pixel's ray tree is done, then reads the image back.
    pub fn render(
        &self,
        scene: &GpuMixedScene,
        camera: &Camera,
        options: &RayTraceOptions,
    ) -> Result<(image::RgbaImage, MixedFrameStats)> {
        camera.validate()?;
        let ctx = &self.ctx;
        let device = ctx.device();
        let (w, h) = (camera.width, camera.height);
        let pixels = w as u64 * h as u64;
        let mut bufs = TraceBuffers::new(&self.tracer, ctx, (w, h), scene.gaussians.len(), false)?;
        let tree = TreeBuffers::new(ctx, pixels, bufs.batches)?;
        let mut params = scene.params;
        let [a, b] = lo_hi(tree.rays.address);
        let [c, d] = lo_hi(scene.clips.address);
        params.refs2 = [a, b, c, d];
        let [a, b] = lo_hi(tree.trace_lists.address);
        params.lists = [a, b, bufs.batch_rays, 0];
        let mut timer = PassTimer::new(ctx)?;
        let mut stats = MixedFrameStats::default();
        let add_times = |timer: &PassTimer, stats: &mut MixedFrameStats| -> Result<()> {
            for p in timer.read()? {
                match stats.passes.iter_mut().find(|(n, _)| *n == p.name) {
                    Some(slot) => slot.1 += p.ms,
                    None => stats.passes.push((p.name, p.ms)),
                }
            }
            Ok(())
        };
        let camera_params = super::tracer::camera_params(camera, &scene.gaussians, options);
        let list = |k: u32| tree.lists.address + (k as u64 & 1) * pixels * 4;
        let mut count_in = pixels as u32;
        for generation in 0..MAX_GENERATIONS {
            // The ray tree's step: the next ray of every pixel, and how many there are.
            let push = SpawnPush {
                mixed: tree.params.address,
                camera: tree.camera.address,
                state: bufs.state.address,
                acc: tree.acc.address,
                cur: tree.cur.address,
                cur_hit: tree.cur_hit.address,
                cur_tri: tree.cur_tri.address,
                stack: tree.stack.address,
                sp: tree.sp.address,
                counters: tree.counters.address,
                list_in: list(generation + 1),
                list_out: list(generation),
                batch_counts: tree.batch_counts.address,
                generation,
                pixels: pixels as u32,
                count_in,
                pad: 0,
            };
            ctx.run_commands(|cmd| {
                timer.begin_frame(cmd);
                unsafe {
                    if generation == 0 {
                        device.cmd_update_buffer(
                            cmd,
                            tree.params.raw,
                            0,
                            bytemuck::bytes_of(&params),
                        );
                        device.cmd_update_buffer(cmd, tree.camera.raw, 0, &camera_params);
                        device.cmd_fill_buffer(cmd, tree.counters.raw, 0, vk::WHOLE_SIZE, 0);
                    } else {
                        device.cmd_fill_buffer(cmd, tree.counters.raw, 0, 4, 0);
                    }
                    device.cmd_fill_buffer(cmd, tree.batch_counts.raw, 0, vk::WHOLE_SIZE, 0);
                }
                compute_barrier(ctx, cmd);
                timer.begin_pass(cmd, c"ray tree");
                self.spawn.dispatch(cmd, &push, linear_grid(count_in));
                timer.end_pass(cmd, c"ray tree");
                crate::vk::buffer::copy_parts_to_host(
                    ctx,
                    cmd,
                    &[
                        (&tree.counters, 0),
                        (&tree.batch_counts, MIXED_COUNTER_WORDS as u64 * 4),
                    ],
                    &tree.readback,
                );
            })?;
            add_times(&timer, &mut stats)?;
            if tree.counter(MIXED_COUNTER_LONG_WALKS) > 0 {
                return Err(Error::InvalidInput(format!(
                    "mixed scene: {} rays walked more than {MIXED_MESH_VISITS_MAX} nodes of the \
                     meshes' BVH, near what lavapipe runs in one invocation (65,535 loop \
                     iterations); fewer triangles along such rays would fit",
                    tree.counter(MIXED_COUNTER_LONG_WALKS)
                )));
            }
            if tree.counter(MIXED_COUNTER_OVERFLOW) > 0 {
                return Err(Error::InvalidInput(format!(
                    "mixed scene: {} rays did not fit a pixel's stack of {MIXED_STACK}",
                    tree.counter(MIXED_COUNTER_OVERFLOW)
                )));
            }
            count_in = tree.counter(MIXED_COUNTER_LIVE);
            if count_in == 0 {
                stats.generations = generation;
                break;
            }
            if generation + 1 == MAX_GENERATIONS {
                return Err(Error::InvalidInput(format!(
                    "mixed scene: ray trees still live after {MAX_GENERATIONS} generations"
                )));
            }
            // The Gaussians along every pixel's ray, batch by batch, rounds until done.
            for batch in 0..bufs.batches {
                // (A batch with no ray this generation is still recorded: the first call of a
                // generation sets up its counters; its dispatches are then empty.)
                let mixed = MixedRays {
                    params: tree.params.address,
                    clips: scene.clips.address,
                    build_bvh: generation == 0,
                    listed_rays: tree.batch_count(batch),
                };
                let mut end = 0;
                let mut next = FIRST_GENERATION_ROUNDS;
                loop {
                    ctx.run_commands(|cmd| {
                        timer.begin_frame(cmd);
                        self.tracer.record(
                            ctx,
                            cmd,
                            &mut timer,
                            &mut bufs,
                            &scene.gaussians,
                            camera,
                            &scene.clip0,
                            options,
                            batch..batch + 1,
                            end..next,
                            Some(mixed),
                            None,
                            None,
                            None,
                            None,
                        )
                    })??;
                    add_times(&timer, &mut stats)?;
                    end = next;
                    if bufs.live_after(batch, end) == 0 {
                        break;
                    }
                    if end == MAX_TRACE_ROUNDS {
                        return Err(Error::InvalidInput(format!(
                            "mixed scene: rays still live after {MAX_TRACE_ROUNDS} rounds"
                        )));
                    }
                    next = (end * 2).min(MAX_TRACE_ROUNDS);
                }
            }
        }
        stats.primary = tree.counter(MIXED_COUNTER_PRIMARY) as u64;
        stats.secondary = tree.counter(MIXED_COUNTER_SECONDARY) as u64;
        stats.shadow = tree.counter(MIXED_COUNTER_SHADOW) as u64;
        stats.cut = tree.counter(MIXED_COUNTER_CUT) as u64;
        let acc: Vec<[f32; 4]> = tree.acc.download_as(pixels as usize)?;
        let img = image::RgbaImage::from_fn(w, h, |i, j| {
            let s = acc[(j * w + i) as usize];
            image::Rgba(crate::reference::rasterize::to_rgba8(glam::Vec3::new(
                s[0], s[1], s[2],
            )))
        });
        Ok((img, stats))
    }
}
