//! The `--stats` file: one JSON object per frame.
//!
//! Keys (stable; later features add keys, none change meaning): `frame`, `pipeline`,
//! `decal_method` (the method applied, which may differ from the one asked for: `none` when the
//! device can run no decal method in this pipeline), `decal_surface` (where the decal pass read
//! each pixel's surface: `gbuffer`, `ids` (the prepass's instance and triangle ids) or `depth`;
//! `null` when no decal pass ran), `tier`,
//! `device`, `size` `[w, h]`, `gpu_ms` (one key per pass, summed over the times it ran, plus
//! `total`), `wall_ms` (from the previous frame's submission to this one's: the frame time the
//! game sees, waits for the GPU included; 0 for the first frame), `cpu_ms` (`frame`: the whole
//! update up to submission, GPU waits left out;
//! `extract`; `animate`: sampling animation clips; `propagate`: transform propagation; `skin`:
//! skinned meshes' joint matrices; `record`; `prepare`: the part of `record` spent preparing the
//! frame's data and writing the scene's uploads into staging; and `submit`: the part of `record`
//! spent in the driver's queue submission), `animation` (`players` advanced, of them `sampled`:
//! those whose poses were written this update (the animation budget, `--animation-budget`, defers
//! the others), and `max_period`: the longest period in frames), and `counters` (`bytes_uploaded`, `records_written`, `blas_builds`,
//! `blas_updates`, `tlas_builds`, `instances`, `lights`, `decals`, `transparent`: blended instances drawn,
//! `shadow_map_views`: atlas tiles drawn, `shadow_maps_missing`: lights the atlas had no room
//! for), and `memory` (GPU memory allocated at the frame's end, in bytes: `textures`,
//! `mesh_pool` (of which `posed_meshes`: the posed copies), `acceleration_structures`, `targets`,
//! `tables` (the scene's records), `lists` (other device-local buffers, most written by the GPU),
//! `host_visible` (staging, readbacks), their `total` (`posed_meshes` aside),
//! `textures_by_format`, keyed by Vulkan format name, e.g. `R8G8B8A8_SRGB`, and `texture_budget`:
//! `budget` (0: none), `resident` (the scene's textures), `levels_dropped` and `bytes_dropped`
//! to fit it, since the start). The run's glTF imports add `counters.texture_cache_hits`,
//! `textures_compressed`, `textures_rebuilt`, `textures_rgba8` and `textures_ktx2`.
//!
//! Decal lists. `clusters`, in frames that applied clustered decals or still hold their lists
//! (`capacity` > 0: for a second after they last ran): `clusters`, `capacity`, `limit` (the
//! memory ceiling), `grows`, `shrinks` (since the start); and, only in frames that applied them,
//! what the GPU measured in frame `measured_frame` (the one that last used this frame slot;
//! absent until one has): `entries` (needed), `dropped` (entries that did not fit),
//! `clusters_used`, `max_per_cluster`, `mean_per_cluster` (entries over used clusters), and,
//! where a decal pass walked the lists (not in forward and Forward+, whose shading walks them
//! itself), `pixels` and per pixel `mean_tested`, `max_tested` (list entries walked) and
//! `mean_applied`, `max_applied` (decals whose box held the pixel). `decal_lists`, the same way
//! for the ray-tracing-pipeline decal pass's per-pixel lists: `capacity`, `limit`, `grows`,
//! `shrinks`, and `measured`: `measured_frame`, `needed` (entries the pixels asked for),
//! `denied` (pixels given no room), `overflowed` (pixels that found more than their room).
//!
//! Transparency: `transparency` (the method applied: `interlaced`, `interlaced_pairs`,
//! `forward` or `depth_peeling`) and `refraction` (whether glass refracts: interlaced and
//! depth-peeled glass do). Anti-aliasing: `aa` (`none`, `fxaa` or `taa`, as applied: `none` for temporal anti-aliasing under a debug view).
//!
//! Reflections: `reflections`: `mode` (applied: `off` or `ray_traced`), `half_resolution`, and
//! what the GPU measured two frames earlier: `pixels` (that reflect), `rays`, `hits` (the rest
//! saw the sky), `decals_tested` and `lights_found` at the hit points, `through_glass`.
//!
//! Environment: `environment`: `filtered` (sources filtered since the start: a frame that
//! refilters nothing leaves it unchanged) and `resolution` (the cubes' face size; 0 before an
//! environment was first used).
//!
//! Lights: `light_method` (applied: `all`, `tiled` or `ray_query`), `direct_light` (applied: `exhaustive`,
//! `stochastic`, `auto`, or `none` without traced shadows of light lists or ray-query lights), `staged_lights` (whether
//! compute shading read its long unshadowed lists a workgroup at a time), `shadows` (`ray_query`, `ray_pipeline`, `maps`
//! (devices without ray tracing, or `--shadow-maps`), or `none`), `lights` (the settings:
//! `tile_size`, `aabb`, `shadow_ray_culling`, `normals`, `coloured_shadows`, and `depth_mask` as
//! applied: off without tiled lights and in frames that light particles), the counters `scene_blas_builds`,
//! `scene_blas_compactions`, `scene_tlas_builds`, `scene_tlas_updates`, `light_blas_builds`,
//! `light_blas_updates`, and, in frames with tiled lights or a light list still held,
//! `light_tiles`: `tiles`, `tile_size`, `capacity`, `grows`, and, only in frames with tiled
//! lights, what the GPU measured in `measured_frame`: `entries`, `overflowed`, `max_per_tile`,
//! `tiles_used`, `mean_per_tile` (entries over used tiles), `sampled_tiles` (tiles whose pixels
//! sampled their lights' shadows: `direct_light`).
//!
//! Culling (`render/src/culling`): `counters.draw_calls` (draw commands the CPU recorded this
//! frame, every pass: each indirect draw covers a batch), `counters.mesh_pool_bytes`, and
//! `culling`: `mode` (`off`, `frustum`, `occlusion`), `frozen`, and what the GPU measured for
//! the main view in `measured_frame` (absent until one has): `instances` (tested),
//! `after_frustum`, `after_occlusion` (drawn), `dropped` (draws that found their list full:
//! never expected), `lod_instances` (instances drawn at each level of detail, level 0 first:
//! `render/src/lod`) and `triangles` (what the main view's lists drew at those levels). `lod_pixels`
//! is the limit the levels were chosen by (0: off).
//!
//! Skinning (`render/src/skinning`): `counters.skinned_meshes` and `skinned_vertices` (posed
//! meshes and vertices the skinning pass wrote this frame), `scene_blas_refits` (their BLASes
//! refit; rebuilds count in `scene_blas_builds`), `scene_blas_refits_deferred` and
//! `scene_blas_stalest` (posed meshes smaller on screen than `--refit-pixels` whose refit waits,
//! and the most frames one has waited), `visited.poses` (skinned instances whose pose
//! extraction set), and the `skinning`, `scene_blas_refit` and `scene_blas_build` passes in
//! `gpu_ms`.
//!
//! Temporal anti-aliasing (`render/src/taa`, `render/src/motion`): `counters.motion_movers`
//! (instances drawn over the camera's motion because they moved or were posed), and the
//! `motion_camera`, `motion_movers`, `taa` and `taa_output` passes in `gpu_ms`.
//!
//! Particles (`render/src/particles`), once an emitter has existed: `particles`: `capacity` (the
//! pool), and what the GPU counted in `measured_frame` (two frames back): `alive` (after its
//! simulation), and since the start `spawned`, `landed` (touched a surface, once each) and
//! `dropped` (not started: the pool was full), `decals_born` (decals landing particles left,
//! `plugins::particles::LeftDecal`; the ring keeps the newest); `visited.emitters` (emitters inserted this
//! frame); the `particles_emit`, `particles_simulate` and `particles` (drawing) passes in
//! `gpu_ms`.

use plugins::FrameStats;
use serde_json::{Map, Value, json};

/// One frame's statistics as a JSON object.
pub fn frame_json(stats: &FrameStats, tier: &str, device: &str) -> Value {
    let mut gpu = Map::new();
    // A pass that runs more than once a frame (depth peeling's second layer) gets its sum.
    for (name, ms) in stats.gpu.iter() {
        let sum = gpu.get(name).and_then(Value::as_f64).unwrap_or(0.0) as f32 + ms;
        gpu.insert(name.to_string(), json!(round(sum)));
    }
    gpu.insert("total".into(), json!(round(stats.gpu.total_ms)));
    let c = &stats.counters;
    let mut value = json!({
        "frame": stats.frame,
        "pipeline": stats.pipeline.name(),
        "decal_method": stats.decal_method.name(),
        "decal_surface": stats.decal_surface.map(|s| s.name()),
        "light_method": stats.light_method.name(),
        "shadows": stats.shadows.name(),
        "transparency": stats.transparency.name(),
        "refraction": stats.refraction,
        "aa": stats.aa.name(),
        "lights": {
            "tile_size": stats.lights.tile(),
            "aabb": stats.lights.cull_aabb,
            "depth_mask": stats.depth_mask,
            "shadow_ray_culling": stats.lights.shadow_ray_culling,
            "normals": match stats.lights.normals { render::DepthNormals::Naive => "naive", render::DepthNormals::Improved => "improved" },
            "coloured_shadows": stats.lights.coloured_shadows,
        },
        "tier": tier,
        "device": device,
        "size": [stats.size.0, stats.size.1],
        "gpu_ms": gpu,
        "wall_ms": round(stats.wall_ms),
        "cpu_ms": {
            "frame": round(stats.cpu_frame_ms),
            "extract": round(stats.cpu_extract_ms),
            "animate": round(stats.cpu_animate_ms),
            "propagate": round(stats.cpu_propagate_ms),
            "skin": round(stats.cpu_skin_ms),
            "record": round(stats.cpu_record_ms),
            "submit": round(stats.cpu_submit_ms),
            "prepare": round(stats.cpu_prepare_ms),
        },
        "visited": {
            "instances": stats.visited.instances,
            "lights": stats.visited.lights,
            "decals": stats.visited.decals,
            "poses": stats.visited.poses,
        },
        "counters": {
            "bytes_uploaded": c.bytes_uploaded,
            "records_written": c.records_written,
            "blas_builds": c.blas_builds,
            "blas_updates": c.blas_updates,
            "tlas_builds": c.tlas_builds,
            "scene_blas_builds": c.scene_blas_builds,
            "scene_blas_compactions": c.scene_blas_compactions,
            "scene_tlas_builds": c.scene_tlas_builds,
            "scene_tlas_updates": c.scene_tlas_updates,
            "light_blas_builds": c.light_blas_builds,
            "light_blas_updates": c.light_blas_updates,
            "instances": c.instances,
            "lights": c.lights,
            "decals": c.decals,
            "transparent": c.transparent,
            "shadow_map_views": c.shadow_map_views,
            "shadow_maps_missing": c.shadow_maps_missing,
            "draw_calls": c.draw_calls,
            "mesh_pool_bytes": c.mesh_pool_bytes,
            "skinned_meshes": c.skinned_meshes,
            "motion_movers": c.motion_movers,
            "skinned_vertices": c.skinned_vertices,
            "scene_blas_refits": c.scene_blas_refits,
        },
        "culling": culling_json(&c.culling),
        "reflections": reflections_json(&c.reflections),
        "environment": { "filtered": c.environment.filtered, "resolution": c.environment.resolution },
        "tonemap": stats.tonemapper.name(),
        "bloom": stats.bloom,
        "ao": stats.occlusion.name(),
        "auto_exposure": stats.auto_exposure,
    });
    // The command buffer: submitted again as recorded, or recorded (`render::gpu::commands`).
    // How the traced shadows of the light lists were made (`crate::lights::sampling`).
    value["direct_light"] = json!(stats.direct_light.map_or("none", |d| d.name()));
    // Whether shading staged its workgroups' long unshadowed light lists (`render::gpu::pipeline::Specialization`).
    value["staged_lights"] = json!(stats.staged_lights);
    // Players sampled and deferred by the animation budget (`engine::animation::AnimationBudget`).
    let a = &stats.animation;
    // And the skins posed as compact skeletons (`engine::animation::CompactSkeleton`): all of
    // them, and those posed this update.
    value["animation"] = json!({
        "players": a.players,
        "sampled": a.sampled,
        "max_period": a.max_period,
        "compact_skins": a.compact_skins,
        "compact_posed": a.compact_posed,
    });
    // Recorded on the render thread while the next update ran (`plugins::pipelined`).
    value["pipelined"] = json!(stats.pipelined);
    value["counters"]["commands_reused"] = json!(c.commands_reused);
    value["counters"]["command_words"] = json!(c.command_words);
    // Refits deferred for posed meshes small on screen (`render::accel`).
    value["counters"]["scene_blas_refits_deferred"] = json!(c.scene_blas_refits_deferred);
    value["counters"]["scene_blas_stalest"] = json!(c.scene_blas_stalest);
    // Each list buffer also while it is held unused (for a second after its method last ran), with
    // its room only: what it measured belongs to the frames that used it.
    let clustered = stats.decal_method == render::DecalMethod::Clustered;
    if clustered || c.clusters.capacity > 0 {
        value["clusters"] = clusters_json(&c.clusters, clustered);
    }
    let listed = stats.decal_method == render::DecalMethod::RayPipeline;
    if listed || c.decal_lists.capacity > 0 {
        let l = &c.decal_lists;
        value["decal_lists"] = json!({ "capacity": l.capacity, "limit": l.limit, "grows": l.grows, "shrinks": l.shrinks });
        if listed && l.measured_frame != u64::MAX {
            value["decal_lists"]["measured"] =
                json!({ "measured_frame": l.measured_frame, "needed": l.needed, "denied": l.denied, "overflowed": l.overflowed });
        }
    }
    let tiled = stats.light_method == render::LightMethod::Tiled;
    if tiled || c.light_tiles.capacity > 0 {
        value["light_tiles"] = light_tiles_json(&c.light_tiles, tiled);
    }
    // Particles, as the GPU counted them in the frame named (two frames before this one), once
    // an emitter has existed (`render::particles`).
    let p = &c.particles;
    if p.capacity > 0 {
        value["particles"] = json!({
            "measured_frame": p.measured_frame,
            "alive": p.alive,
            "spawned": p.spawned,
            "landed": p.landed,
            "dropped": p.dropped,
            "decals_born": p.decals_born,
            "capacity": p.capacity,
        });
    }
    value["visited"]["emitters"] = json!(stats.visited.emitters);
    value["memory"] = memory_json(&c.memory);
    value["memory"]["posed_meshes"] = json!(c.posed_mesh_bytes);
    let b = &c.texture_budget;
    value["memory"]["texture_budget"] =
        json!({ "budget": b.budget, "resident": b.resident, "levels_dropped": b.levels_dropped, "bytes_dropped": b.bytes_dropped });
    value
}

/// What the run's glTF imports did to their textures, since the start: `counters.texture_cache_hits`
/// (read compressed from the cache), `textures_compressed` (cache misses), `textures_rebuilt`
/// (cached files that could not be used), `textures_rgba8` and `textures_ktx2`.
pub fn add_import_counters(value: &mut Value, imports: &engine::gltf::TextureImportStats) {
    let counters = &mut value["counters"];
    counters["texture_cache_hits"] = json!(imports.cache_hits);
    counters["textures_compressed"] = json!(imports.compressed);
    counters["textures_rebuilt"] = json!(imports.rebuilt);
    counters["textures_rgba8"] = json!(imports.rgba8 + imports.reused);
    counters["textures_ktx2"] = json!(imports.ktx2);
}

/// GPU memory at the end of the frame: bytes by kind, their `total`, and `textures_by_format`
/// keyed by Vulkan format name.
fn memory_json(m: &render::gpu::memory::MemoryCounts) -> Value {
    let mut v = Map::new();
    for kind in render::gpu::memory::MemoryKind::ALL {
        v.insert(kind.name().into(), json!(m.of(kind)));
    }
    v.insert("total".into(), json!(m.total()));
    let formats: Map<String, Value> = m.texture_formats().map(|(f, bytes)| (format!("{f:?}"), json!(bytes))).collect();
    v.insert("textures_by_format".into(), Value::Object(formats));
    Value::Object(v)
}

fn reflections_json(k: &render::reflections::ReflectionStats) -> Value {
    let mut v = json!({
        "mode": k.applied.name(),
        "half_resolution": k.half_resolution,
        "decals_at_hits": k.decals_at_hits,
        "smoothest": round(k.smoothest),
    });
    if k.measured_frame != u64::MAX && k.applied != render::ReflectionMode::Off {
        v["measured_frame"] = json!(k.measured_frame);
        v["pixels"] = json!(k.pixels);
        v["rays"] = json!(k.rays);
        v["hits"] = json!(k.hits);
        v["decals_tested"] = json!(k.decals_tested);
        v["lights_found"] = json!(k.lights_found);
        v["through_glass"] = json!(k.through_glass);
    }
    v
}

fn culling_json(k: &render::CullingStats) -> Value {
    let mut v = json!({ "mode": k.mode.name(), "frozen": k.frozen, "lod_pixels": k.lod_pixels });
    if k.measured_frame != u64::MAX {
        v["measured_frame"] = json!(k.measured_frame);
        v["instances"] = json!(k.instances);
        v["after_frustum"] = json!(k.after_frustum);
        v["after_occlusion"] = json!(k.after_occlusion);
        v["dropped"] = json!(k.dropped);
        v["lod_instances"] = json!(k.lod_instances);
        v["triangles"] = json!(k.triangles);
    }
    v
}

/// The light tiles' statistics; what the GPU measured only when `used` this frame.
fn light_tiles_json(t: &render::lights::tiles::LightTileStats, used: bool) -> Value {
    let mut v = json!({ "tiles": t.tiles, "tile_size": t.tile_size, "capacity": t.capacity, "grows": t.grows });
    if used && t.measured_frame != u64::MAX {
        v["measured_frame"] = json!(t.measured_frame);
        v["entries"] = json!(t.entries);
        v["overflowed"] = json!(t.overflowed);
        v["max_per_tile"] = json!(t.max_per_tile);
        v["tiles_used"] = json!(t.tiles_used);
        v["sampled_tiles"] = json!(t.sampled_tiles);
        v["mean_per_tile"] = json!(if t.tiles_used == 0 { 0.0 } else { (t.entries as f64 / t.tiles_used as f64 * 100.0).round() / 100.0 });
    }
    v
}

/// The decal clusters' statistics; what the GPU measured only when `used` this frame.
fn clusters_json(k: &render::stats::DecalClusterStats, used: bool) -> Value {
    let mut v = json!({ "clusters": k.clusters, "capacity": k.capacity, "limit": k.limit, "grows": k.grows, "shrinks": k.shrinks });
    if used && k.measured_frame != u64::MAX {
        let mean = |sum: u64, n: u64| if n == 0 { 0.0 } else { (sum as f64 / n as f64 * 100.0).round() / 100.0 };
        let mut measured = json!({
            "measured_frame": k.measured_frame,
            "entries": k.entries,
            "dropped": k.dropped,
            "clusters_used": k.clusters_used,
            "max_per_cluster": k.max_per_cluster,
            "mean_per_cluster": mean(k.entries, k.clusters_used),
        });
        // Per pixel only where a decal pass walked the lists (forward shading walks them itself
        // and counts nothing).
        if k.pixels > 0 {
            let per_pixel = json!({
                "pixels": k.pixels,
                "mean_tested": mean(k.tested, k.pixels),
                "max_tested": k.max_tested,
                "mean_applied": mean(k.applied, k.pixels),
                "max_applied": k.max_applied,
            });
            for (key, value) in per_pixel.as_object().expect("an object") {
                measured[key] = value.clone();
            }
        }
        for (key, value) in measured.as_object().expect("an object") {
            v[key] = value.clone();
        }
    }
    v
}

fn round(ms: f32) -> f64 {
    (ms as f64 * 1e4).round() / 1e4
}
