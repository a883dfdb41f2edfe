//! Image-based light and the sky. Seed 000 (`seeds/000`, §2.3) lists an ambient term among its
//! renderer's shading options and uses a constant; a game renderer lights with its surroundings
//! instead. The environment is a procedural sky (the default: its sun is the scene's brightest
//! directional light, so it follows time of day), an HDR map (an equirectangular Radiance `.hdr`,
//! or a KTX2 cube map whose six faces the source pass samples in the face each direction
//! selects; loaded by `engine::environment`), or a uniform radiance (the white furnace's),
//! turned about +Y and scaled by an intensity at no cost.
//!
//! **Filtered when the source changes, never per frame** (Bevy #24517 refiltered generated
//! environment maps every frame, 58 → 13 fps). On such a frame, compute passes:
//!
//! 1. `environment_source`: the radiance cube's level 0, from the map (bilinear; a cube map's
//!    within the face, any size: its own levels are not read, since the passes filter), the sky or the
//!    uniform colour; then each further level box-filtered from the one above.
//! 2. `environment_irradiance`: diffuse irradiance as nine spherical-harmonic coefficients
//!    (Ramamoorthi and Hanrahan 2001), one workgroup over a 32² level.
//! 3. `environment_prefilter`: the specular cube, level `i` prefiltered for perceptual roughness
//!    `i / (levels − 1)` by GGX importance sampling under the split sum's n = v = r (Karis 2013,
//!    "Real Shading in Unreal Engine 4"), each sample read from the radiance level matching its
//!    solid angle (Křivánek and Colbert 2008).
//! 4. Once, the split sum's BRDF table (`shaders/brdf_lut.comp`), integrated with our own
//!    height-correlated Smith term so the environment's specular matches the lights'.
//!
//! Shading (`shaders/include/environment.glsl`, every pipeline, glass and the reflection rays'
//! hit points) adds the prefiltered radiance × (F0·A + B) × specular occlusion, the irradiance ×
//! diffuse colour × occlusion, and Fdez-Agüera's (2019) multiple-scattering compensation, so a
//! white furnace holds for rough metals too. Reflection rays that miss see the environment, and
//! a traced reflection replaces exactly the prefiltered radiance shading added. The sky pass
//! draws the radiance cube behind everything, and the procedural sky's sun disc.
//!
//! **Design.** The cubes are RGBA16F and live in the GENERAL layout: their passes write them as
//! storage images (one 2D-array view per level, `BINDING_ENVIRONMENT_LEVELS`) and shading samples
//! them there, so no pass needs a per-level layout; the frame graph orders the uses through two
//! logical resources (the images, the record). Their face size is fixed at creation
//! ([`crate::RendererSettings::environment_resolution`]): a new source refilters into the same
//! images, so descriptors are written once and nothing is allocated but the job's host-visible
//! buffers (its parameters, kept until the next job so that the lighting record does not change
//! again; a map's texels, read by the source pass through their address, and freed after the
//! frame).

use ash::vk;
use glam::{Vec2, Vec3, Vec4};
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, GPU_WRITTEN, Image, ImageDesc, MemoryKind, Retired};
use crate::gpu::pipeline::{ScenePush, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::f16_to_f32;
use crate::graph::{BufferUse, Frame, FrameGraph, ImageUse, PassKind, ResourceId};
use crate::layout::{
    BINDING_BRDF_LUT, BINDING_BRDF_LUT_STORAGE, BINDING_ENVIRONMENT, BINDING_ENVIRONMENT_LEVELS, BINDING_ENVIRONMENT_SOURCE, BRDF_LUT_SIZE,
    ENVIRONMENT_CUBE_MAP, ENVIRONMENT_MAP, ENVIRONMENT_ON, ENVIRONMENT_SKY, ENVIRONMENT_SPECULAR_VIEWS, ENVIRONMENT_SUN_DISC,
    ENVIRONMENT_UNIFORM, GpuEnvironment, GpuEnvironmentJob, LIGHT_DIRECTIONAL,
};
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::DebugView;

/// Format of the environment's cubes.
const CUBE_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Most levels of the specular cube (roughness steps of 0.2; the last level's faces are the
/// face size / 32).
pub const MAX_SPECULAR_LEVELS: u32 = 6;
/// The smallest face size accepted (the irradiance pass's 32² level, a 4-texel last level).
pub const MIN_RESOLUTION: u32 = 32;
/// The largest (a 2048² face: an 8k map's detail).
pub const MAX_RESOLUTION: u32 = 2048;
/// Angular radius of the procedural sky's sun disc (the real sun's, 0.27°).
const SUN_DISC_RADIUS: f32 = 0.0047;

pub use crate::scene::environment::{Environment, EnvironmentMap, EnvironmentSource, MapProjection};

/// What the frame's passes need of the environment: the lighting record's fields and the
/// resources shading reads.
#[derive(Clone, Copy, Debug, Default)]
pub struct EnvironmentFrame {
    /// Address of the `GpuEnvironment` record (0: no environment).
    pub record: u64,
    /// Address of the last filtering job (0 before the first).
    pub job: u64,
    /// `ENVIRONMENT_*` flags.
    pub flags: u32,
    /// (cos, sin) of the rotation.
    pub rotation: Vec2,
    /// Radiance multiplier.
    pub intensity: f32,
    /// The specular cube's last level.
    pub max_level: f32,
    /// What shading reads: the images (sampled) and the record (storage).
    pub reads: Option<[ResourceId; 2]>,
    /// Whether this frame filters a new source.
    pub filters: bool,
}

impl EnvironmentFrame {
    /// Whether an environment lights this frame.
    pub fn on(&self) -> bool {
        self.flags & ENVIRONMENT_ON != 0
    }
}

/// What a pass that samples the environment reads: its images and its record (`environment`:
/// this frame's, `None` without one).
pub fn environment_reads(environment: Option<[ResourceId; 2]>) -> impl Iterator<Item = (ResourceId, BufferUse)> {
    environment.into_iter().flat_map(|[images, record]| [(images, BufferUse::SampledImages), (record, BufferUse::Storage)])
}

/// One level of an environment cube read back ([`crate::Renderer::read_environment`]).
#[derive(Clone, Debug)]
pub struct CubeLevel {
    /// Side of its faces in texels.
    pub size: u32,
    /// Linear RGBA texels, face after face (+X, −X, +Y, −Y, +Z, −Z), rows downwards.
    pub texels: Vec<[f32; 4]>,
}

/// The GPU images of an environment, made on first use and kept.
struct Cubes {
    source: Image,
    specular: Image,
    lut: Image,
    /// One 2D-array view per level: the source's, then the specular cube's.
    level_views: Vec<vk::ImageView>,
    record: Buffer,
    sampler: vk::Sampler,
    /// The images have not been written yet (their first pass moves them to GENERAL).
    fresh: bool,
}

/// What the last filtered source was (a new one refilters).
#[derive(Clone, Debug, PartialEq)]
enum Filtered {
    Sky { sun: Vec3, color: Vec3 },
    Map(EnvironmentMap),
    Uniform(Vec3),
}

pub use crate::stats::EnvironmentStats;

/// The environment's passes and images.
pub struct Environments {
    source: vk::Pipeline,
    downsample: vk::Pipeline,
    irradiance: vk::Pipeline,
    prefilter: vk::Pipeline,
    lut: vk::Pipeline,
    /// The sky pass: over depth 0, and over the uncovered fraction of MSAA's pixels.
    sky: [vk::Pipeline; 2],
    resolution: u32,
    cubes: Option<Cubes>,
    filtered: Option<Filtered>,
    /// The last filtering job (`GpuEnvironmentJob`), kept until the next so that the lighting
    /// record's address stays valid and unchanged.
    job: Option<Buffer>,
    /// The map's texels on a frame that filters one (freed after it).
    texels: Option<Buffer>,
    warned_bad_map: bool,
    /// The sun as last found ([`sun_of`]), looked for again only on frames whose light records
    /// changed: a scene of a million lights is not scanned every frame.
    sun: Option<(Vec3, Vec3)>,
    images_res: ResourceId,
    record_res: ResourceId,
    /// Counters.
    pub stats: EnvironmentStats,
}

/// The brightest directional light of the scene as the sun: its direction towards the light and
/// its illuminance; a default sun high in the south-west when there is none.
fn sun_of(mirror: &SceneMirror) -> (Vec3, Vec3) {
    let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    mirror
        .lights
        .records()
        .iter()
        .filter(|l| l.kind == LIGHT_DIRECTIONAL)
        .max_by(|a, b| luminance(a.color).total_cmp(&luminance(b.color)))
        .map(|l| (-l.direction.normalize_or(Vec3::NEG_Y), l.color))
        .unwrap_or((Vec3::new(0.4, 0.8, 0.45).normalize(), Vec3::splat(4.0)))
}

impl Environments {
    /// Creates the pipelines; images are made when an environment is first used, with faces of
    /// `resolution` texels (clamped to [`MIN_RESOLUTION`]..=[`MAX_RESOLUTION`], a power of two).
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout, resolution: u32) -> Result<Self, RenderError> {
        let compute = |name, spirv| create_compute(ctx, layout, name, spirv);
        Ok(Self {
            source: compute("environment source", shaders::ENVIRONMENT_SOURCE_COMP)?,
            downsample: compute("environment downsample", shaders::ENVIRONMENT_DOWNSAMPLE_COMP)?,
            irradiance: compute("environment irradiance", shaders::ENVIRONMENT_IRRADIANCE_COMP)?,
            prefilter: compute("environment prefilter", shaders::ENVIRONMENT_PREFILTER_COMP)?,
            lut: compute("brdf table", shaders::BRDF_LUT_COMP)?,
            sky: [compute("sky", shaders::SKY_COMP)?, compute("sky", shaders::SKY_COMP_COVERAGE)?],
            resolution: resolution.clamp(MIN_RESOLUTION, MAX_RESOLUTION).next_power_of_two(),
            cubes: None,
            filtered: None,
            job: None,
            texels: None,
            warned_bad_map: false,
            sun: None,
            images_res: graph.resource("environment images"),
            record_res: graph.resource("environment record"),
            stats: EnvironmentStats::default(),
        })
    }

    fn source_levels(&self) -> u32 {
        self.resolution.ilog2() + 1
    }

    fn specular_levels(&self) -> u32 {
        self.source_levels().min(MAX_SPECULAR_LEVELS)
    }

    /// Makes the images on first use and binds them.
    fn cubes(&mut self, ctx: &GpuContext, scene: &GpuScene) -> Result<&mut Cubes, RenderError> {
        if self.cubes.is_none() {
            let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED;
            let extent = vk::Extent2D { width: self.resolution, height: self.resolution };
            let desc = |name, mip_levels| ImageDesc {
                name,
                format: CUBE_FORMAT,
                extent,
                mip_levels,
                usage,
                samples: 1,
                kind: MemoryKind::Textures,
            };
            let source = Image::cube(ctx, &desc("environment radiance", self.source_levels()))?;
            let specular = Image::cube(ctx, &desc("environment specular", self.specular_levels()))?;
            let lut_extent = vk::Extent2D { width: BRDF_LUT_SIZE, height: BRDF_LUT_SIZE };
            let lut = Image::new(
                ctx,
                &ImageDesc {
                    name: "brdf table",
                    format: vk::Format::R16G16_SFLOAT,
                    extent: lut_extent,
                    mip_levels: 1,
                    usage,
                    samples: 1,
                    kind: MemoryKind::Textures,
                },
            )?;
            let mut level_views = Vec::new();
            for level in 0..source.mip_levels {
                level_views.push(source.level_view(ctx, level)?);
            }
            for level in 0..specular.mip_levels {
                level_views.push(specular.level_view(ctx, level)?);
            }
            let record = Buffer::new(ctx, "environment record", size_of::<GpuEnvironment>() as u64, GPU_WRITTEN, MemoryLocation::GpuOnly)?;
            // SAFETY: a valid create info; destroyed in `destroy`.
            let sampler = unsafe {
                ctx.device.create_sampler(
                    &vk::SamplerCreateInfo::default()
                        .mag_filter(vk::Filter::LINEAR)
                        .min_filter(vk::Filter::LINEAR)
                        .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                        .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .max_lod(vk::LOD_CLAMP_NONE),
                    None,
                )?
            };
            scene.bind_general(ctx, BINDING_ENVIRONMENT, 0, specular.view, sampler);
            scene.bind_general(ctx, BINDING_ENVIRONMENT_SOURCE, 0, source.view, sampler);
            scene.bind_general(ctx, BINDING_BRDF_LUT, 0, lut.view, sampler);
            scene.bind_general(ctx, BINDING_BRDF_LUT_STORAGE, 0, lut.view, vk::Sampler::null());
            for (i, &view) in level_views.iter().enumerate() {
                let index =
                    if (i as u32) < source.mip_levels { i as u32 } else { ENVIRONMENT_SPECULAR_VIEWS + i as u32 - source.mip_levels };
                scene.bind_general(ctx, BINDING_ENVIRONMENT_LEVELS, index, view, vk::Sampler::null());
            }
            self.stats.resolution = self.resolution;
            self.cubes = Some(Cubes { source, specular, lut, level_views, record, sampler, fresh: true });
        }
        Ok(self.cubes.as_mut().expect("made above"))
    }

    /// Decides what this frame does with the environment: nothing without one; else makes the
    /// images on first use and, when the source (or the procedural sky's sun) changed, writes the
    /// filtering job for [`Environments::record`]. Call before the lighting record is set.
    pub fn prepare(&mut self, f: &mut Frame, scene: &GpuScene, mirror: &SceneMirror) -> Result<EnvironmentFrame, RenderError> {
        let Some(env) = mirror.environment() else {
            return Ok(EnvironmentFrame::default());
        };
        if self.sun.is_none() || mirror.lights.dirty_count() > 0 {
            self.sun = Some(sun_of(mirror));
        }
        let (sun, sun_color) = self.sun.expect("found above");
        let sky = EnvironmentSource::Sky;
        let source = match &env.source {
            EnvironmentSource::Map(m) if !m.is_valid() => {
                if !self.warned_bad_map {
                    tracing::warn!(
                        m.width,
                        m.height,
                        texels = m.texels.len(),
                        "environment map's size, projection and texels disagree; the procedural sky lights the scene"
                    );
                    self.warned_bad_map = true;
                }
                &sky
            }
            s => s,
        };
        let wanted = match source {
            EnvironmentSource::Sky => Filtered::Sky { sun, color: sun_color },
            EnvironmentSource::Map(map) => Filtered::Map(map.clone()),
            EnvironmentSource::Uniform(c) => Filtered::Uniform(*c),
        };
        let filters = match (&self.filtered, &wanted) {
            (Some(Filtered::Sky { sun: a, color: ca }), Filtered::Sky { sun: b, color: cb }) => {
                a.dot(*b) < 0.99999 || (*ca - *cb).abs().max_element() > 1e-4 * cb.max_element().max(1e-3)
            }
            (old, new) => old.as_ref() != Some(new),
        };
        let (source_levels, specular_levels, resolution) = (self.source_levels(), self.specular_levels(), self.resolution);
        let cubes = self.cubes(f.ctx, scene)?;
        let record = cubes.record.address;
        if filters {
            let mut record = GpuEnvironmentJob {
                sun: sun.extend(SUN_DISC_RADIUS.cos()),
                sun_color: sun_color.extend(0.0),
                color: Vec4::ZERO,
                source: 0,
                source_size: [0, 0],
                mode: ENVIRONMENT_SKY,
                face: resolution,
                source_levels,
                specular_levels,
            };
            let texels: &[[f32; 3]] = match source {
                EnvironmentSource::Map(map) => {
                    record.mode = match map.projection {
                        MapProjection::Equirectangular => ENVIRONMENT_MAP,
                        MapProjection::CubeFaces => ENVIRONMENT_CUBE_MAP,
                    };
                    record.source_size = [map.width, map.height];
                    &map.texels
                }
                EnvironmentSource::Uniform(c) => {
                    record.mode = ENVIRONMENT_UNIFORM;
                    record.color = c.extend(1.0);
                    &[]
                }
                EnvironmentSource::Sky => &[],
            };
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
            if !texels.is_empty() {
                let bytes = std::mem::size_of_val(texels) as u64;
                let mut buffer = Buffer::new(f.ctx, "environment map texels", bytes, usage, MemoryLocation::CpuToGpu)?;
                buffer.mapped()[..bytes as usize].copy_from_slice(bytemuck::cast_slice(texels));
                record.source = buffer.address;
                f.upload.bytes += bytes;
                self.texels = Some(buffer);
            }
            let mut buffer = Buffer::new(f.ctx, "environment job", size_of::<GpuEnvironmentJob>() as u64, usage, MemoryLocation::CpuToGpu)?;
            buffer.mapped()[..size_of::<GpuEnvironmentJob>()].copy_from_slice(bytemuck::bytes_of(&record));
            f.upload.bytes += size_of::<GpuEnvironmentJob>() as u64;
            if let Some(old) = self.job.replace(buffer) {
                f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old));
            }
            self.filtered = Some(wanted);
            self.stats.filtered += 1;
        }
        let sky = matches!(source, EnvironmentSource::Sky);
        let turns = if sky { 0.0 } else { env.rotation };
        Ok(EnvironmentFrame {
            record,
            job: self.job.as_ref().map_or(0, |j| j.address),
            flags: ENVIRONMENT_ON | if sky { ENVIRONMENT_SUN_DISC } else { 0 },
            rotation: Vec2::new(turns.cos(), turns.sin()),
            intensity: env.intensity.max(0.0),
            max_level: (specular_levels - 1) as f32,
            reads: Some([self.images_res, self.record_res]),
            filters,
        })
    }

    /// Records the filtering passes on a frame that filters (after the lighting record's
    /// upload): the radiance cube and its levels, the irradiance, the specular cube, and the
    /// BRDF table the first time. The job's buffer is freed after the frame.
    pub fn record(&mut self, f: &mut Frame, scene: &GpuScene, frame: &EnvironmentFrame) -> Result<(), RenderError> {
        if !frame.filters {
            return Ok(());
        }
        let (images, record) = (self.images_res, self.record_res);
        let cubes = self.cubes.as_mut().expect("prepare made the images");
        let fresh = std::mem::take(&mut cubes.fresh);
        let new_images = if fresh {
            vec![
                (cubes.source.raw, cubes.source.full_range()),
                (cubes.specular.raw, cubes.specular.full_range()),
                (cubes.lut.raw, cubes.lut.full_range()),
            ]
        } else {
            Vec::new()
        };
        let face = self.resolution;
        let groups = |level: u32| (face >> level).max(1).div_ceil(8);
        let tables = scene.res.tables;
        let pipeline = self.source;
        f.pass("environment_source", PassKind::Compute).read(tables, BufferUse::Storage).storage_images(images, new_images).record(
            |p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(groups(0), groups(0), 6);
            },
        )?;
        // A pass that samples the radiance cube, writes `written`, gets its level through
        // `scene.texture_index` and dispatches `(side, side, faces)` workgroups.
        let level_pass = |f: &mut Frame, name, pipeline, level: u32, written: ResourceId, (side, faces): (u32, u32)| {
            f.pass(name, PassKind::Compute)
                .read(tables, BufferUse::Storage)
                .read(images, BufferUse::SampledImages)
                .write(written, BufferUse::Storage)
                .record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &ScenePush { texture_index: level, ..p.push });
                    p.cmd.dispatch(side, side, faces);
                })
        };
        for level in 1..self.source_levels() {
            level_pass(f, "environment_downsample", self.downsample, level, images, (groups(level), 6))?;
        }
        level_pass(f, "environment_irradiance", self.irradiance, 0, record, (1, 1))?;
        for level in 0..self.specular_levels() {
            level_pass(f, "environment_prefilter", self.prefilter, level, images, (groups(level), 6))?;
        }
        if fresh {
            let pipeline = self.lut;
            f.pass("brdf_table", PassKind::Compute).write(images, BufferUse::Storage).record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                let groups = BRDF_LUT_SIZE.div_ceil(8);
                p.cmd.dispatch(groups, groups, 1);
            })?;
        }
        if let Some(texels) = self.texels.take() {
            f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(texels));
        }
        Ok(())
    }

    /// Whether the sky pass draws this frame: with an environment (`environment`: its images
    /// and record this frame, the lighting frame's), in the lit view and the reflections' (the
    /// other debug views show their values over the clear colour).
    pub fn draws_sky(&self, environment: Option<[ResourceId; 2]>, view: DebugView) -> bool {
        environment.is_some() && matches!(view, DebugView::Lit | DebugView::Reflections)
    }

    /// The sky pass: where no geometry was drawn, the environment in the view direction (after
    /// the opaque shading, before reflections and glass), when [`Environments::draws_sky`].
    /// `coverage`: the HDR target was resolved from MSAA's samples, its alpha the covered
    /// fraction of each pixel, and the sky fills the rest (`crate::msaa`).
    pub fn sky(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        environment: Option<[ResourceId; 2]>,
        view: DebugView,
        coverage: bool,
    ) -> Result<(), RenderError> {
        if !self.draws_sky(environment, view) {
            return Ok(());
        }
        let pipeline = self.sky[usize::from(coverage)];
        f.pass("sky", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .reads(environment_reads(environment))
            .when(!coverage, |p| p.sample(&crate::graph::targets::DEPTH))
            .image(&crate::graph::targets::HDR, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(p.extent.width.div_ceil(8), p.extent.height.div_ceil(8), 1);
            })
    }

    /// Level `level` of the radiance cube (`specular` false) or of the specular cube, as
    /// linear RGBA texels, face after face (+X, −X, +Y, −Y, +Z, −Z; rows downwards), and the
    /// level's side; `None` before an environment was first used. Waits for the GPU; for tests.
    pub fn read_level(
        &self,
        ctx: &GpuContext,
        graph: &mut FrameGraph,
        specular: bool,
        level: u32,
    ) -> Result<Option<CubeLevel>, RenderError> {
        let Some(cubes) = &self.cubes else { return Ok(None) };
        let image = if specular { &cubes.specular } else { &cubes.source };
        if level >= image.mip_levels {
            return Err(RenderError::Other(format!("the environment cube has {} levels, not {}", image.mip_levels, level + 1)));
        }
        let bytes = graph.read_back_general_image(ctx, self.images_res, image, level, 8)?;
        let texels =
            bytes.chunks_exact(8).map(|px| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([px[c * 2], px[c * 2 + 1]])))).collect();
        Ok(Some(CubeLevel { size: (image.extent.width >> level).max(1), texels }))
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(mut self, ctx: &GpuContext) {
        for p in [self.source, self.downsample, self.irradiance, self.prefilter, self.lut].into_iter().chain(self.sky) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some(c) = self.cubes.take() {
            // SAFETY: the GPU is idle.
            unsafe {
                for v in c.level_views {
                    ctx.destroying().destroy_image_view(v, None);
                }
                ctx.destroying().destroy_sampler(c.sampler, None);
            }
            c.source.destroy(ctx);
            c.specular.destroy(ctx);
            c.lut.destroy(ctx);
            c.record.destroy(ctx);
        }
        for b in [self.job.take(), self.texels.take()].into_iter().flatten() {
            b.destroy(ctx);
        }
    }
}
