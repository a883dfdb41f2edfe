//! SPIR-V compiled from `shaders/` by `build.rs` (glslc), and shader-module creation.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;

macro_rules! spirv {
    ($($name:ident = $file:literal;)*) => {
        $(
            #[doc = concat!("SPIR-V of `shaders/", $file, "`.")]
            pub const $name: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/", $file, ".spv"));
        )*
    };
}

spirv! {
    PARTICLES_INIT_COMP = "particles_init.comp";
    PARTICLES_LIGHT_COMP = "particles_light.comp";
    PARTICLES_EMIT_COMP = "particles_emit.comp";
    PARTICLES_SIMULATE_COMP = "particles_simulate.comp";
    PARTICLE_VERT = "particle.vert";
    PARTICLE_FRAG = "particle.frag";
    PARTICLE_VERT_MOTION = "particle.vert.MOTION";
    PARTICLE_FRAG_MOTION = "particle.frag.MOTION";
    MESH_VERT = "mesh.vert";
    CULL_COMP = "cull.comp";
    SKINNING_COMP = "skinning.comp";
    HIZ_COMP = "hiz.comp";
    REFLECTION_HIZ_COMP = "reflection_hiz.comp";
    PREPASS_MASK_FRAG = "prepass_mask.frag";
    FORWARD_FRAG = "forward.frag";
    FORWARD_FRAG_RAY_QUERY_DECALS = "forward.frag.RAY_QUERY_DECALS";
    FULLSCREEN_VERT = "fullscreen.vert";
    TONEMAP_FRAG = "tonemap.frag";
    TONEMAP_FRAG_ANTIALIASED = "tonemap.frag.ANTIALIASED";
    FXAA_COMP = "fxaa.comp";
    SMAA_EDGES_COMP = "smaa_edges.comp";
    SMAA_WEIGHTS_COMP = "smaa_weights.comp";
    SMAA_BLEND_COMP = "smaa_blend.comp";
    EXPOSURE_HISTOGRAM_COMP = "exposure_histogram.comp";
    EXPOSURE_AVERAGE_COMP = "exposure_average.comp";
    REFLECTIONS_COMP = "reflections.comp";
    REFLECTIONS_COMP_RAY_QUERY_DECALS = "reflections.comp.RAY_QUERY_DECALS";
    REFLECTIONS_COMP_DECAL_BUFFER = "reflections.comp.DECAL_BUFFER";
    REFLECTIONS_COMP_CLUSTERED_DECALS = "reflections.comp.CLUSTERED_DECALS";
    REFLECTIONS_COMP_GBUFFER = "reflections.comp.GBUFFER";
    REFLECTIONS_COMP_GBUFFER_RAY_QUERY_DECALS = "reflections.comp.GBUFFER+RAY_QUERY_DECALS";
    REFLECTIONS_COMP_GBUFFER_DECAL_BUFFER = "reflections.comp.GBUFFER+DECAL_BUFFER";
    ENVIRONMENT_SOURCE_COMP = "environment_source.comp";
    ENVIRONMENT_DOWNSAMPLE_COMP = "environment_downsample.comp";
    ENVIRONMENT_IRRADIANCE_COMP = "environment_irradiance.comp";
    ENVIRONMENT_PREFILTER_COMP = "environment_prefilter.comp";
    BRDF_LUT_COMP = "brdf_lut.comp";
    SKY_COMP = "sky.comp";
    SKY_COMP_COVERAGE = "sky.comp.COVERAGE";
    BLOOM_COMP = "bloom.comp";
    BLOOM_COMP_FIRST = "bloom.comp.FIRST";
    BLOOM_COMP_DOWN = "bloom.comp.DOWN";
    BLOOM_COMP_UP = "bloom.comp.UP";
    REFLECTIONS_RESOLVE_COMP = "reflections_resolve.comp";
    REFLECTIONS_RESOLVE_COMP_GLASS_LAYER = "reflections_resolve.comp.GLASS_LAYER";
    REFLECTIONS_RESOLVE_COMP_SEPARATE = "reflections_resolve.comp.SEPARATE";
    FORWARD_FRAG_MSAA_REFLECTED = "forward.frag.MSAA+REFLECTED";
    FORWARD_FRAG_MSAA_REFLECTED_RAY_QUERY_DECALS = "forward.frag.MSAA+REFLECTED+RAY_QUERY_DECALS";
    FORWARD_FRAG_MSAA_REFLECTED_DECAL_BUFFER = "forward.frag.MSAA+REFLECTED+DECAL_BUFFER";
    FORWARD_FRAG_MSAA_REFLECTED_CLUSTERED_DECALS = "forward.frag.MSAA+REFLECTED+CLUSTERED_DECALS";
    REFLECTIONS_COMP_GLASS_LAYER = "reflections.comp.GLASS_LAYER";
    REFLECTIONS_RGEN_GLASS_LAYER = "reflections.rgen.GLASS_LAYER";
    SCREEN_REFLECTIONS_COMP = "screen_reflections.comp";
    SCREEN_REFLECTIONS_COMP_RAY_QUERY_DECALS = "screen_reflections.comp.RAY_QUERY_DECALS";
    SCREEN_REFLECTIONS_COMP_DECAL_BUFFER = "screen_reflections.comp.DECAL_BUFFER";
    SCREEN_REFLECTIONS_COMP_CLUSTERED_DECALS = "screen_reflections.comp.CLUSTERED_DECALS";
    SCREEN_REFLECTIONS_COMP_GBUFFER = "screen_reflections.comp.GBUFFER";
    SCREEN_REFLECTIONS_COMP_GBUFFER_RAY_QUERY_DECALS = "screen_reflections.comp.GBUFFER+RAY_QUERY_DECALS";
    SCREEN_REFLECTIONS_COMP_GBUFFER_DECAL_BUFFER = "screen_reflections.comp.GBUFFER+DECAL_BUFFER";
    REFLECTIONS_RGEN = "reflections.rgen";
    REFLECTIONS_RGEN_DECAL_BUFFER = "reflections.rgen.DECAL_BUFFER";
    REFLECTIONS_RGEN_CLUSTERED_DECALS = "reflections.rgen.CLUSTERED_DECALS";
    REFLECTIONS_RGEN_GBUFFER = "reflections.rgen.GBUFFER";
    REFLECTIONS_RGEN_GBUFFER_DECAL_BUFFER = "reflections.rgen.GBUFFER+DECAL_BUFFER";
    REFLECTIONS_RCHIT = "reflections.rchit";
    REFLECTIONS_RAHIT = "reflections.rahit";
    REFLECTIONS_RMISS = "reflections.rmiss";
    LIGHT_RAYS_RAHIT_SHADOWED_LIGHTS = "light_rays.rahit.SHADOWED_LIGHTS";
    LIGHT_RAYS_RMISS_SHADOWED_LIGHTS = "light_rays.rmiss.SHADOWED_LIGHTS";
    DECAL_BOXES_VERT = "decal_boxes.vert";
    GBUFFER_FRAG = "gbuffer.frag";
    GBUFFER_FRAG_ALPHA_MASK = "gbuffer.frag.ALPHA_MASK";
    GBUFFER_FRAG_GLASS = "gbuffer.frag.GLASS";
    GBUFFER_FRAG_INTERLACED = "gbuffer.frag.GLASS+INTERLACED_ROWS";
    TRANSPARENCY_COMPOSE_COMP = "transparency_compose.comp";
    TRANSPARENCY_COMPOSE_COMP_SEED_PAIRS = "transparency_compose.comp.SEED_PAIRS";
    TRANSPARENCY_PEELED_COMP = "transparency_peeled.comp";
    PEELING_KEEP_DEPTH_COMP = "peeling_keep_depth.comp";
    DEFERRED_LIGHTING_FRAG = "deferred_lighting.frag";
    DEFERRED_LIGHTING_FRAG_RAY_QUERY_DECALS = "deferred_lighting.frag.RAY_QUERY_DECALS";
    DECAL_BOX_VERT = "decal_box.vert";
    DEFERRED_DECAL_FRAG = "deferred_decal.frag";
    VISBUFFER_FRAG = "visbuffer.frag";
    VISBUFFER_FRAG_ALPHA_MASK = "visbuffer.frag.ALPHA_MASK";
    VISBUFFER_SHADE_FRAG = "visbuffer_shade.frag";
    VISBUFFER_SHADE_FRAG_RAY_QUERY_DECALS = "visbuffer_shade.frag.RAY_QUERY_DECALS";
    FLAT_COLOR_FRAG = "flat_color.frag";
    FORWARD_FRAG_DECAL_BUFFER = "forward.frag.DECAL_BUFFER";
    FORWARD_FRAG_CLUSTERED_DECALS = "forward.frag.CLUSTERED_DECALS";
    FORWARD_FRAG_MSAA = "forward.frag.MSAA";
    FORWARD_FRAG_MSAA_RAY_QUERY_DECALS = "forward.frag.MSAA+RAY_QUERY_DECALS";
    FORWARD_FRAG_MSAA_DECAL_BUFFER = "forward.frag.MSAA+DECAL_BUFFER";
    FORWARD_FRAG_MSAA_CLUSTERED_DECALS = "forward.frag.MSAA+CLUSTERED_DECALS";
    FORWARD_FRAG_TRANSPARENT = "forward.frag.TRANSPARENT";
    FORWARD_FRAG_TRANSPARENT_RAY_QUERY_DECALS = "forward.frag.TRANSPARENT+RAY_QUERY_DECALS";
    FORWARD_FRAG_SHADOWED_GLASS = "forward.frag.TRANSPARENT+SHADOWED_GLASS";
    FORWARD_FRAG_SHADOWED_GLASS_RAY_QUERY_DECALS = "forward.frag.TRANSPARENT+SHADOWED_GLASS+RAY_QUERY_DECALS";
    DEFERRED_LIGHTING_FRAG_DECAL_BUFFER = "deferred_lighting.frag.DECAL_BUFFER";
    VISBUFFER_SHADE_FRAG_DECAL_BUFFER = "visbuffer_shade.frag.DECAL_BUFFER";
    DECAL_PASS_RGEN = "decal_pass.rgen";
    DECAL_PASS_RGEN_VISIBILITY = "decal_pass.rgen.DECAL_SURFACE_VISIBILITY";
    DECAL_PASS_RGEN_DEPTH = "decal_pass.rgen.DECAL_SURFACE_DEPTH";
    DECAL_PASS_RGEN_COUNT_ONLY_DEPTH = "decal_pass.rgen.COUNT_ONLY+DECAL_SURFACE_DEPTH";
    DECAL_PASS_RMISS = "decal_pass.rmiss";
    DECAL_PASS_RINT = "decal_pass.rint";
    DECAL_PASS_RAHIT = "decal_pass.rahit";
    DECAL_PASS_RGEN_COUNT_ONLY = "decal_pass.rgen.COUNT_ONLY";
    DECAL_PASS_RGEN_COUNT_ONLY_VISIBILITY = "decal_pass.rgen.COUNT_ONLY+DECAL_SURFACE_VISIBILITY";
    DECAL_PASS_RAHIT_COUNT_ONLY = "decal_pass.rahit.COUNT_ONLY";
    DECAL_PASS_RAHIT_COLLECT = "decal_pass.rahit.COLLECT";
    DECAL_PASS_RAHIT_LIST = "decal_pass.rahit.LIST";
    DECAL_LIST_OFFSETS_COMP = "decal_list_offsets.comp";
    DECAL_PASS_COMP = "decal_pass.comp";
    DECAL_PASS_COMP_VISIBILITY = "decal_pass.comp.DECAL_SURFACE_VISIBILITY";
    DECAL_PASS_COMP_DEPTH = "decal_pass.comp.DECAL_SURFACE_DEPTH";
    DECAL_CLUSTERS_COMP = "decal_clusters.comp";
    DECAL_CLUSTERS_COMP_FILL = "decal_clusters.comp.FILL";
    DECAL_CLUSTERS_COMP_WIDE = "decal_clusters.comp.WIDE";
    DECAL_CLUSTERS_COMP_FILL_WIDE = "decal_clusters.comp.FILL+WIDE";
    DECAL_CLUSTER_SCAN_COMP = "decal_cluster_scan.comp";
    DECAL_CLUSTER_BOUNDS_COMP = "decal_cluster_bounds.comp";
    DECAL_PASS_CLUSTERED_COMP = "decal_pass_clustered.comp";
    DECAL_PASS_CLUSTERED_COMP_VISIBILITY = "decal_pass_clustered.comp.DECAL_SURFACE_VISIBILITY";
    DECAL_PASS_CLUSTERED_COMP_DEPTH = "decal_pass_clustered.comp.DECAL_SURFACE_DEPTH";
    LIGHT_TILE_FRUSTA_COMP = "light_tile_frusta.comp";
    LIGHT_CULL_COMP = "light_cull.comp";
    LIGHT_CULL_COMP_TRANSPARENT = "light_cull.comp.TRANSPARENT";
    SHADOWS_COMP = "shadows.comp";
    SHADOWS_COMP_GLASS_LAYER = "shadows.comp.GLASS_LAYER";
    SHADOWS_MAPPED_COMP = "shadows_mapped.comp";
    SHADOWS_MAPPED_COMP_GLASS_LAYER = "shadows_mapped.comp.GLASS_LAYER";
    SHADOW_MAP_VERT = "shadow_map.vert";
    SHADOW_MAP_FRAG = "shadow_map.frag";
    SHADOWS_RGEN = "shadows.rgen";
    SHADOWS_RGEN_GLASS_LAYER = "shadows.rgen.GLASS_LAYER";
    SHADOWS_RMISS = "shadows.rmiss";
    SHADOWS_RAHIT = "shadows.rahit";
    OCCLUSION_COMP = "occlusion.comp";
    OCCLUSION_COMP_SCREEN_SPACE = "occlusion.comp.SCREEN_SPACE";
    OCCLUSION_RGEN = "occlusion.rgen";
    OCCLUSION_DENOISE_COMP = "occlusion_denoise.comp";
    MOTION_CAMERA_COMP = "motion_camera.comp";
    MOTION_CAMERA_COMP_VISIBILITY = "motion_camera.comp.VISIBILITY";
    MOTION_CAMERA_COMP_GBUFFER = "motion_camera.comp.GBUFFER";
    MOTION_VERT = "motion.vert";
    MOTION_FRAG = "motion.frag";
    TAA_COMP = "taa.comp";
    TAA_COMP_HISTORY_B = "taa.comp.HISTORY_B";
    TAA_OUTPUT_COMP = "taa_output.comp";
    TAA_OUTPUT_COMP_HISTORY_B = "taa_output.comp.HISTORY_B";
    SCENE_INSTANCES_COMP = "scene_instances.comp";
    DEFERRED_LIGHTING_COMP = "deferred_lighting.comp";
    DEFERRED_LIGHTING_COMP_RAY_QUERY_DECALS = "deferred_lighting.comp.RAY_QUERY_DECALS";
    DEFERRED_LIGHTING_COMP_DECAL_BUFFER = "deferred_lighting.comp.DECAL_BUFFER";
    VISBUFFER_SHADE_COMP = "visbuffer_shade.comp";
    VISBUFFER_SHADE_COMP_RAY_QUERY_DECALS = "visbuffer_shade.comp.RAY_QUERY_DECALS";
    VISBUFFER_SHADE_COMP_DECAL_BUFFER = "visbuffer_shade.comp.DECAL_BUFFER";
    DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS = "deferred_lighting.comp.RAY_QUERY_LIGHTS";
    DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS_RAY_QUERY_DECALS = "deferred_lighting.comp.RAY_QUERY_LIGHTS+RAY_QUERY_DECALS";
    DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS_DECAL_BUFFER = "deferred_lighting.comp.RAY_QUERY_LIGHTS+DECAL_BUFFER";
    VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS = "visbuffer_shade.comp.RAY_QUERY_LIGHTS";
    VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS_RAY_QUERY_DECALS = "visbuffer_shade.comp.RAY_QUERY_LIGHTS+RAY_QUERY_DECALS";
    VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS_DECAL_BUFFER = "visbuffer_shade.comp.RAY_QUERY_LIGHTS+DECAL_BUFFER";
    DEFERRED_LIGHTING_RGEN = "deferred_lighting.rgen";
    DEFERRED_LIGHTING_RGEN_DECAL_BUFFER = "deferred_lighting.rgen.DECAL_BUFFER";
    VISBUFFER_SHADE_RGEN = "visbuffer_shade.rgen";
    VISBUFFER_SHADE_RGEN_DECAL_BUFFER = "visbuffer_shade.rgen.DECAL_BUFFER";
    LIGHT_RAYS_RINT = "light_rays.rint";
    LIGHT_RAYS_RAHIT = "light_rays.rahit";
    LIGHT_RAYS_RMISS = "light_rays.rmiss";
    LIGHT_BOXES_COMP = "light_boxes.comp";
}

/// Creates a shader module from SPIR-V bytes.
pub fn module(ctx: &GpuContext, spirv: &[u8]) -> Result<vk::ShaderModule, RenderError> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).map_err(|e| RenderError::Other(format!("bad SPIR-V: {e}")))?;
    // SAFETY: `words` is SPIR-V produced by glslc at build time.
    Ok(unsafe { ctx.device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None) }?)
}
