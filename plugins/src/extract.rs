//! Extraction: change-detection systems that keep the [`RenderMirror`] in step with the World.
//!
//! Each system looks only at what changed this frame: `Changed`/`Added` filters for components,
//! `RemovedComponents` for despawns, and asset events for meshes, images and materials. Records
//! go into stable slots keyed by entity (or asset handle), so a frame in which nothing changed
//! writes nothing and uploads nothing.

use bevy_ecs::entity::{EntityHashMap, EntityHashSet};
use bevy_ecs::message::MessageReader;
use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParam;
use bevy_tasks::ComputeTaskPool;
use engine::animation::{MorphWeights, Skin, SkinPose};
use engine::asset::{AssetEvent, Assets, Handle};
use engine::camera::Camera;
use engine::changes::Inserted;
use engine::image::{ColorSpace, Image, TexelFormat};
use engine::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use engine::material::{AlphaMode, Material};
use engine::mesh::Mesh;
use engine::scene::MeshInstance;
use engine::time::Time;
use engine::transform::{GlobalTransform, TransformChanges};
use glam::{Mat4, Vec2, Vec3};
use render::scene::poses::PoseSet;
use render::scene::{
    DrawItem, GpuCamera, GpuInstance, GpuLight, GpuMaterial, MATERIAL_ALPHA_MASK, MATERIAL_BLEND, MATERIAL_DOUBLE_SIDED, MeshId,
    PreparedDecal, SceneMirror, TEXTURE_FLAT_NORMAL, TEXTURE_WHITE, TextureData,
};
use std::collections::HashMap;

use crate::decal::{DEFAULT_RECEIVER_LAYERS, Decal, DecalLifetimes, DecalMaterial, DecalReceiver, decal_desc, gpu_decal_material};
use crate::validate::{self, WarnOnce};
use crate::{RenderMirror, RenderSettings, RenderStats};

/// Where each asset and entity lives in the mirror.
#[derive(Resource, Default)]
pub struct MirrorSlots {
    meshes: HashMap<Handle<Mesh>, MeshId>,
    textures: HashMap<Handle<Image>, u32>,
    materials: HashMap<Handle<Material>, (u32, DrawFlags)>,
    instances: EntityHashMap<u32>,
    lights: EntityHashMap<u32>,
    decals: EntityHashMap<u32>,
    /// The light slots of emitting decals (`DecalMaterial::emits_light`).
    decal_lights: EntityHashMap<u32>,
    decal_materials: HashMap<Handle<DecalMaterial>, u32>,
    /// Particle emitters (`crate::particles`).
    pub(crate) emitters: EntityHashMap<u32>,
    /// Skinned instances' posed meshes (and the skinned mesh each copies).
    posed: EntityHashMap<(MeshId, MeshId)>,
    /// Skinned instances whose posed mesh is new: posed in this frame whatever moved.
    fresh_poses: Vec<Entity>,
    /// The poses set this frame (kept for its memory).
    pose_batch: Vec<PoseSet<(Entity, bool)>>,
    /// The slot of the material used when an instance's material is missing.
    pub default_material: u32,
}

impl MirrorSlots {
    /// The light-table slot of a light entity, once extracted.
    pub fn light_slot(&self, entity: Entity) -> Option<u32> {
        self.lights.get(&entity).copied()
    }
}

/// Entities that found their table at its [`crate::SceneLimits`] limit and wait for room.
#[derive(Default)]
pub struct Waiting {
    entities: EntityHashSet,
    warned: bool,
}

impl Waiting {
    /// Whether `entity`, which has no slot yet, may take one in a table of `live` records:
    /// otherwise it waits (one warning when the table first fills up).
    fn admit(&mut self, entity: Entity, live: usize, limit: u32, what: &str) -> bool {
        if live < limit as usize {
            self.forget(entity);
            return true;
        }
        self.entities.insert(entity);
        if !self.warned {
            self.warned = true;
            tracing::warn!(
                "the {what} limit of {limit} is reached: further {what}s are not drawn until others are despawned (RenderSettings::limits)"
            );
        }
        false
    }

    /// `entity` no longer waits (despawned, admitted, or no longer drawable).
    fn forget(&mut self, entity: Entity) {
        if self.entities.is_empty() {
            return;
        }
        self.entities.remove(&entity);
        if self.entities.is_empty() {
            self.warned = false;
        }
    }

    /// Up to as many waiting entities as there is room for in a table of `live` records.
    fn retry(&self, live: usize, limit: u32) -> Vec<Entity> {
        let room = (limit as usize).saturating_sub(live);
        if room == 0 { Vec::new() } else { self.entities.iter().copied().take(room).collect() }
    }

    /// Number of entities waiting.
    fn len(&self) -> u64 {
        self.entities.len() as u64
    }
}

/// The bookkeeping of an entity-extracting system: who was warned about, who waits for room.
#[derive(Default)]
pub struct EntityChecks {
    warned: WarnOnce<Entity>,
    waiting: Waiting,
}

#[derive(Clone, Copy, Debug, PartialEq, Default)]
struct DrawFlags {
    alpha_mask: bool,
    double_sided: bool,
    transparent: bool,
}

impl MirrorSlots {
    /// Empty maps; `default_material` is the slot used for instances without a material.
    pub fn new(default_material: u32) -> Self {
        Self { default_material, ..Default::default() }
    }

    /// The instance slot of `entity`, if it is mirrored.
    pub fn instance(&self, entity: Entity) -> Option<u32> {
        self.instances.get(&entity).copied()
    }

    /// The light slot of `entity`, if it is mirrored.
    pub fn light(&self, entity: Entity) -> Option<u32> {
        self.lights.get(&entity).copied()
    }

    /// The decal slot of `entity`, if it is mirrored.
    pub fn decal(&self, entity: Entity) -> Option<u32> {
        self.decals.get(&entity).copied()
    }

    /// The material slot of `handle`, if it is mirrored.
    pub fn material(&self, handle: Handle<Material>) -> Option<u32> {
        self.materials.get(&handle).map(|(slot, _)| *slot)
    }

    /// The decal material slot of `handle`, if it is mirrored.
    pub fn decal_material(&self, handle: Handle<DecalMaterial>) -> Option<u32> {
        self.decal_materials.get(&handle).copied()
    }

    /// The decal material mirrored in `slot`, if any (a search: for reading back, not for
    /// every frame).
    pub fn decal_material_handle(&self, slot: u32) -> Option<Handle<DecalMaterial>> {
        self.decal_materials.iter().find(|&(_, &s)| s == slot).map(|(h, _)| *h)
    }

    /// The emitter slot of `entity`, if it is mirrored (`crate::particles`).
    pub fn emitter(&self, entity: Entity) -> Option<u32> {
        self.emitters.get(&entity).copied()
    }

    /// The bindless texture slot of `handle`, if it is mirrored.
    pub fn texture(&self, handle: Handle<Image>) -> Option<u32> {
        self.textures.get(&handle).copied()
    }
}

fn texture_data(image: &Image) -> TextureData {
    TextureData { width: image.width, height: image.height, format: vk_format(image.format, image.color_space), mips: image.mips.clone() }
}

/// The Vulkan format the renderer samples an image of `format` in `color_space` as (one- and
/// two-channel data is never sRGB).
pub(crate) fn vk_format(format: TexelFormat, color_space: ColorSpace) -> ash::vk::Format {
    use ash::vk::Format as F;
    let srgb = color_space == ColorSpace::Srgb;
    match format {
        TexelFormat::Rgba8 if srgb => F::R8G8B8A8_SRGB,
        TexelFormat::Rgba8 => F::R8G8B8A8_UNORM,
        TexelFormat::Bc1 if srgb => F::BC1_RGBA_SRGB_BLOCK,
        TexelFormat::Bc1 => F::BC1_RGBA_UNORM_BLOCK,
        TexelFormat::Bc1Rgb if srgb => F::BC1_RGB_SRGB_BLOCK,
        TexelFormat::Bc1Rgb => F::BC1_RGB_UNORM_BLOCK,
        TexelFormat::Bc3 if srgb => F::BC3_SRGB_BLOCK,
        TexelFormat::Bc3 => F::BC3_UNORM_BLOCK,
        TexelFormat::Bc4 => F::BC4_UNORM_BLOCK,
        TexelFormat::Bc5 => F::BC5_UNORM_BLOCK,
        TexelFormat::Bc7 if srgb => F::BC7_SRGB_BLOCK,
        TexelFormat::Bc7 => F::BC7_UNORM_BLOCK,
    }
}

/// Uploads new images, re-uploads modified ones, frees removed ones.
pub fn extract_images(
    mut images: ResMut<Assets<Image>>,
    mut mirror: ResMut<RenderMirror>,
    mut slots: ResMut<MirrorSlots>,
    mut materials: ResMut<Assets<Material>>,
    mut decal_materials: ResMut<Assets<DecalMaterial>>,
    mut warned: Local<WarnOnce<Handle<Image>>>,
) {
    let images = &mut *images;
    let mut replaced = Vec::new();
    for event in images.drain_events().collect::<Vec<_>>() {
        let handle = event.handle();
        if let Some(old) = slots.textures.remove(&handle) {
            mirror.0.remove_texture(old);
            replaced.push(handle);
        }
        let Some(image) = images.get(handle).filter(|_| matches!(event, AssetEvent::Added(_) | AssetEvent::Modified(_))) else {
            warned.forget(handle);
            continue;
        };
        let problem = validate::image_problem(image);
        warned.report(handle, "image", problem.as_deref(), "not uploaded; materials sample their fallback texture");
        if problem.is_none() {
            let slot = mirror.0.add_texture(texture_data(image));
            slots.textures.insert(handle, slot);
        }
    }
    if !replaced.is_empty() {
        // Materials that sampled a replaced image must point at its new slot (or the fallback).
        let stale: Vec<_> = materials
            .iter()
            .filter(|(_, m)| {
                [m.base_color_texture, m.metallic_roughness_texture, m.normal_texture, m.occlusion_texture, m.emissive_texture]
                    .into_iter()
                    .flatten()
                    .any(|h| replaced.contains(&h))
            })
            .map(|(h, _)| h)
            .collect();
        for h in stale {
            materials.get_mut(h); // records a Modified event that extract_materials handles
        }
        let stale: Vec<_> = decal_materials
            .iter()
            .filter(|(_, m)| m.textures().into_iter().flatten().any(|h| replaced.contains(&h)))
            .map(|(h, _)| h)
            .collect();
        for h in stale {
            decal_materials.get_mut(h);
        }
    }
}

fn gpu_material(m: &Material, slots: &MirrorSlots) -> (GpuMaterial, DrawFlags) {
    let tex = |h: Option<Handle<Image>>, fallback: u32| h.and_then(|h| slots.textures.get(&h).copied()).unwrap_or(fallback);
    let (alpha_mask, cutoff) = match m.alpha_mode {
        AlphaMode::Opaque | AlphaMode::Blend => (false, 0.0),
        AlphaMode::Mask(c) => (true, c),
    };
    let transparent = m.alpha_mode == AlphaMode::Blend;
    let mut flags = 0;
    if alpha_mask {
        flags |= MATERIAL_ALPHA_MASK;
    }
    if transparent {
        flags |= MATERIAL_BLEND;
    }
    if m.double_sided {
        flags |= MATERIAL_DOUBLE_SIDED;
    }
    let gpu = GpuMaterial {
        base_color: m.base_color.to_array(),
        emissive: m.emissive.to_array(),
        // The built-in flat normal texel (128/255) decodes to a normal tilted by 0.2°, which is
        // visible in sharp highlights; a zero scale makes "no normal map" exactly flat.
        normal_scale: if m.normal_texture.is_some() { m.normal_scale } else { 0.0 },
        metallic: m.metallic,
        roughness: m.roughness,
        alpha_cutoff: cutoff,
        occlusion_strength: m.occlusion_strength,
        base_color_tex: tex(m.base_color_texture, TEXTURE_WHITE),
        metallic_roughness_tex: tex(m.metallic_roughness_texture, TEXTURE_WHITE),
        normal_tex: tex(m.normal_texture, TEXTURE_FLAT_NORMAL),
        occlusion_tex: tex(m.occlusion_texture, TEXTURE_WHITE),
        emissive_tex: tex(m.emissive_texture, TEXTURE_WHITE),
        flags,
        refraction: if transparent { m.refraction() } else { 0.0 },
        pad: 0,
    };
    (gpu, DrawFlags { alpha_mask, double_sided: m.double_sided, transparent })
}

/// Writes added and modified materials into their slots; frees removed ones.
pub fn extract_materials(
    mut materials: ResMut<Assets<Material>>,
    mut mirror: ResMut<RenderMirror>,
    mut slots: ResMut<MirrorSlots>,
    instances: Query<(Entity, &MeshInstance)>,
    mut warned: Local<WarnOnce<Handle<Material>>>,
) {
    let mut changed_flags = Vec::new();
    let events: Vec<_> = materials.drain_events().collect();
    let mirror = &mut mirror.0;
    for event in events {
        let handle = event.handle();
        match (&event, materials.get(handle)) {
            (AssetEvent::Added(_) | AssetEvent::Modified(_), Some(material)) => {
                let (material, problem) = validate::material(material);
                warned.report(handle, "material", problem, "repaired (defaults for non-finite values, the rest clamped); drawn");
                let (gpu, flags) = gpu_material(&material, &slots);
                let old = slots.materials.get(&handle).copied();
                let slot = SceneMirror::write(&mut mirror.records_written, &mut mirror.materials, old.map(|(s, _)| s), gpu);
                slots.materials.insert(handle, (slot, flags));
                if old.is_some_and(|(_, f)| f != flags) {
                    changed_flags.push(handle);
                }
            }
            _ => {
                warned.forget(handle);
                if let Some((slot, _)) = slots.materials.remove(&handle) {
                    mirror.materials.remove(slot);
                    mirror.records_written += 1;
                }
            }
        }
    }
    // An instance's draw item caches its material's alpha mode and sidedness.
    if !changed_flags.is_empty() {
        for (entity, inst) in &instances {
            if changed_flags.contains(&inst.material)
                && let (Some(&slot), Some(&(_, flags))) = (slots.instances.get(&entity), slots.materials.get(&inst.material))
            {
                mirror.update_draw(slot, |draw| {
                    draw.alpha_mask = flags.alpha_mask;
                    draw.double_sided = flags.double_sided;
                    draw.transparent = flags.transparent;
                });
            }
        }
    }
}

/// Uploads added meshes, replaces modified ones, frees removed ones. Broken mesh data is
/// repaired or refused by [`validate::mesh_data`], with one warning per mesh.
pub fn extract_meshes(
    mut meshes: ResMut<Assets<Mesh>>,
    mut mirror: ResMut<RenderMirror>,
    mut slots: ResMut<MirrorSlots>,
    mut warned: Local<WarnOnce<Handle<Mesh>>>,
) {
    let events: Vec<_> = meshes.drain_events().collect();
    for event in events {
        let handle = event.handle();
        if let Some(old) = slots.meshes.remove(&handle) {
            mirror.0.remove_mesh(old);
        }
        let Some(mesh) = meshes.get(handle).filter(|_| matches!(event, AssetEvent::Added(_) | AssetEvent::Modified(_))) else {
            warned.forget(handle);
            continue;
        };
        match validate::mesh_data(mesh) {
            Ok((data, repaired)) => {
                warned.report(handle, "mesh", repaired.as_deref(), "repaired; the rest is drawn");
                let id = mirror.0.add_mesh(data);
                slots.meshes.insert(handle, id);
                repose(&mut mirror.0, &mut slots, id);
            }
            Err(problem) => warned.report(handle, "mesh", Some(&problem), "not drawn"),
        }
    }
}

/// Gives the skinned instances of a mesh that was replaced new posed copies of it. They take
/// the ids of the copies they replace (freed ids are reused last-in first-out), so the instances'
/// records stay as they are; a mesh that lost its skin leaves them drawing nothing until they
/// are re-inserted.
fn repose(mirror: &mut render::SceneMirror, slots: &mut MirrorSlots, source: MeshId) {
    let stale: Vec<(Entity, MeshId)> = slots.posed.iter().filter(|(_, (_, s))| *s == source).map(|(e, (p, _))| (*e, *p)).collect();
    for (entity, posed) in stale {
        mirror.remove_mesh(posed);
        match mirror.add_posed_mesh(source) {
            Some(again) => {
                debug_assert_eq!(again, posed, "a freed mesh id is reused first");
                slots.fresh_poses.push(entity);
            }
            None => {
                slots.posed.remove(&entity);
            }
        }
    }
}

/// Completes a list of entities to visit from what the change lists named: adds what transform
/// propagation moved (those of the system's `kind` only: the rest would be sorted for nothing)
/// and what waits for room, and keeps each entity once.
fn finish_visits(visit: &mut Vec<Entity>, moved: Option<&TransformChanges>, kind: impl Fn(Entity) -> bool, waiting: Vec<Entity>) {
    visit.extend(moved.iter().flat_map(|m| m.moved()).copied().filter(|&entity| kind(entity)));
    visit.extend(waiting);
    visit.sort_unstable();
    visit.dedup();
}

/// The change lists that name mesh instances: inserted instances and decal receiver layers
/// ([`Inserted`] messages), and what transform propagation moved.
#[derive(SystemParam)]
pub struct InstanceChanges<'w, 's> {
    inserted: MessageReader<'w, 's, Inserted<MeshInstance>>,
    receivers: MessageReader<'w, 's, Inserted<DecalReceiver>>,
    moved: Option<Res<'w, TransformChanges>>,
}

impl InstanceChanges<'_, '_> {
    /// Appends every listed entity to `out` (repeats included), of the moved ones only those
    /// `kind` keeps (what propagation moved is mostly not instances: a million moving decals
    /// would be sorted for nothing), and marks the messages read.
    pub fn drain_into(&mut self, out: &mut Vec<Entity>, kind: impl Fn(Entity) -> bool) {
        out.extend(self.inserted.read().map(|m| m.entity));
        out.extend(self.receivers.read().map(|m| m.entity));
        out.extend(self.moved.iter().flat_map(|m| m.moved()).copied().filter(|&entity| kind(entity)));
    }
}

/// Mirrors mesh instances that were spawned, moved, given another mesh or material (a new
/// `MeshInstance` inserted) or other decal layers; frees removed ones. The instances to visit
/// come from change lists ([`Inserted`] messages and [`TransformChanges::moved`]), not from a
/// scan, so a frame in which nothing changed visits none of them.
#[allow(clippy::too_many_arguments)]
pub fn extract_instances(
    all: Query<(&MeshInstance, &GlobalTransform, Option<&DecalReceiver>, Has<Skin>)>,
    mut changes: InstanceChanges,
    (mut removed, mut removed_receivers): (RemovedComponents<MeshInstance>, RemovedComponents<DecalReceiver>),
    (mut mirror, mut slots): (ResMut<RenderMirror>, ResMut<MirrorSlots>),
    live: Query<(), With<MeshInstance>>,
    (mut checks, mut visit): (Local<EntityChecks>, Local<Vec<Entity>>),
    (settings, mut stats): (Res<RenderSettings>, ResMut<RenderStats>),
) {
    let EntityChecks { warned, waiting } = &mut *checks;
    let mirror = &mut mirror.0;
    let limit = settings.limits.clamped().instances;
    visit.clear();
    // An instance that lost its DecalReceiver falls back to the default layers.
    visit.extend(removed_receivers.read());
    for entity in removed.read() {
        if live.contains(entity) {
            visit.push(entity); // removed and re-added in the same frame: handled as a change
            continue;
        }
        warned.forget(entity);
        waiting.forget(entity);
        if let Some(slot) = slots.instances.remove(&entity) {
            mirror.remove_instance(slot);
        }
        if let Some((posed, _)) = slots.posed.remove(&entity) {
            mirror.remove_mesh(posed);
        }
    }
    changes.drain_into(&mut visit, |entity| live.contains(entity));
    finish_visits(&mut visit, None, |_| true, waiting.retry(mirror.instances.len(), limit));
    let mut visited = 0;
    for &entity in visit.iter() {
        let Ok((inst, global, receiver, skinned)) = all.get(entity) else { continue };
        visited += 1;
        let world = global.compute_matrix();
        let mesh = slots.meshes.get(&inst.mesh).copied();
        let problem = match mesh {
            None => Some("refers to a mesh that is not loaded (or has nothing to draw)"),
            Some(_) => validate::placement_problem(world),
        };
        warned.report(entity, "mesh instance", problem, "not drawn until it is fixed");
        let Some(mesh) = mesh.filter(|_| problem.is_none()) else {
            waiting.forget(entity);
            if let Some(slot) = slots.instances.remove(&entity) {
                mirror.remove_instance(slot);
            }
            if let Some((posed, _)) = slots.posed.remove(&entity) {
                mirror.remove_mesh(posed);
            }
            continue;
        };
        let slot = slots.instances.get(&entity).copied();
        if slot.is_none() && !waiting.admit(entity, mirror.instances.len(), limit, "mesh instance") {
            continue;
        }
        // A skinned instance draws a posed copy of its mesh (kept while the mesh stays).
        let posable = (skinned && mirror.poses.is_skinned(mesh)) || mirror.poses.morph_targets(mesh) > 0;
        let mesh = match (posable, slots.posed.get(&entity).copied()) {
            (true, Some((posed, source))) if source == mesh => posed,
            (want, old) => {
                if let Some((posed, _)) = old {
                    mirror.remove_mesh(posed);
                    slots.posed.remove(&entity);
                }
                match want.then(|| mirror.add_posed_mesh(mesh)).flatten() {
                    Some(posed) => {
                        slots.posed.insert(entity, (posed, mesh));
                        slots.fresh_poses.push(entity);
                        posed
                    }
                    None => mesh,
                }
            }
        };
        let (material, flags) = slots.materials.get(&inst.material).copied().unwrap_or((slots.default_material, DrawFlags::default()));
        // Decals land on glass only when a DecalReceiver says so.
        let layers = receiver.map_or(if flags.transparent { 0 } else { DEFAULT_RECEIVER_LAYERS }, |r| r.0);
        let record = GpuInstance::new(world, material, layers);
        let draw = DrawItem { mesh, alpha_mask: flags.alpha_mask, double_sided: flags.double_sided, transparent: flags.transparent };
        let written = mirror.set_instance(slot, record, draw);
        if slot.is_none() {
            slots.instances.insert(entity, written);
        }
    }
    stats.visited.instances = visited;
    stats.over_limit.instances = waiting.len();
}

/// Poses skinned and morphed instances: for each whose [`SkinPose`] changed this frame (its
/// joints or it moved; `engine::animation::update_skin_poses` computes the matrices in
/// parallel), whose [`MorphWeights`] (its own or its glTF node's) changed, or whose posed mesh
/// is new, the matrices and weights go to its posed mesh ([`render::SceneMirror::set_pose`]) and
/// its culling bounds follow the pose. It visits the posed instances (not every instance), and
/// the skinning pass then runs for those that changed.
pub fn extract_poses(
    skins: Query<(Entity, Ref<SkinPose>)>,
    morphs: Query<(Entity, Ref<MorphWeights>, Option<&Children>)>,
    parents: Query<&ChildOf>,
    (mut mirror, mut slots): (ResMut<RenderMirror>, ResMut<MirrorSlots>),
    mut stats: ResMut<RenderStats>,
) {
    let slots = &mut *slots;
    let mirror = &mut mirror.0;
    let mut fresh = std::mem::take(&mut slots.fresh_poses);
    fresh.sort_unstable();
    fresh.dedup();
    // The batch of poses to set: new posed meshes; then the instances whose skin matrices
    // changed; then those whose morph weights (or their node's) changed. Each list names only
    // what changed.
    let mut batch = std::mem::take(&mut slots.pose_batch);
    batch.clear();
    let mut add = |entity: Entity| {
        if let Some(&(mesh, source)) = slots.posed.get(&entity) {
            batch.push(PoseSet::new(mesh, (entity, mirror.poses.morph_targets(source) > 0)));
        }
    };
    fresh.iter().for_each(|&entity| add(entity));
    for (entity, skin) in &skins {
        if skin.is_changed() && fresh.binary_search(&entity).is_err() {
            add(entity);
        }
    }
    for (node, weights, children) in &morphs {
        if weights.is_changed() {
            for entity in std::iter::once(node).chain(children.into_iter().flat_map(|c| c.iter())) {
                if fresh.binary_search(&entity).is_err() && !skins.get(entity).is_ok_and(|(_, s)| s.is_changed()) {
                    add(entity);
                }
            }
        }
    }
    // Set on every core: each pose's matrices converted and its bounds found (10,000 foxes'
    // 240,000 joints took 11 ms of one core).
    let pose_of = |&(entity, morphed): &(Entity, bool)| {
        let joints = skins.get(entity).ok().map_or(&[][..], |(_, s)| &s.into_inner().0[..]);
        // Morph weights are on the glTF node: its own, or its parent's.
        let weights = morphed
            .then(|| morphs.get(entity).ok().or_else(|| parents.get(entity).ok().and_then(|p| morphs.get(p.parent()).ok())))
            .flatten();
        (joints, weights.map_or(&[][..], |(_, w, _)| &w.into_inner().0[..]))
    };
    match ComputeTaskPool::try_get().filter(|pool| pool.thread_num() > 1 && batch.len() > 64) {
        Some(pool) => {
            pool.scope(|scope| {
                for chunk in mirror.poses.chunks(&mut batch, pool.thread_num() * 4) {
                    scope.spawn(async move { chunk.set(pose_of) });
                }
            });
        }
        None => mirror.poses.chunks(&mut batch, 1).for_each(|chunk| chunk.set(pose_of)),
    }
    mirror.finish_poses(&batch);
    let mut posed = 0;
    for set in batch.iter().filter(|s| s.was_set()) {
        posed += 1;
        if let Some(&slot) = slots.instances.get(&set.item.0) {
            mirror.refresh_cull(slot);
        }
    }
    slots.pose_batch = batch;
    fresh.clear();
    slots.fresh_poses = fresh;
    stats.visited.poses = posed;
}

/// Mirrors lights that were spawned, moved or changed (a new light component inserted); frees
/// removed ones. Like instances, the lights to visit come from change lists.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn extract_lights(
    all: Query<(
        &GlobalTransform,
        Option<&PointLight>,
        Option<&SpotLight>,
        Option<&DirectionalLight>,
        Option<&RectLight>,
        Option<&DiskLight>,
    )>,
    (mut inserted_point, mut inserted_spot, mut inserted_dir, mut inserted_rect, mut inserted_disk, moved): (
        MessageReader<Inserted<PointLight>>,
        MessageReader<Inserted<SpotLight>>,
        MessageReader<Inserted<DirectionalLight>>,
        MessageReader<Inserted<RectLight>>,
        MessageReader<Inserted<DiskLight>>,
        Option<Res<TransformChanges>>,
    ),
    (mut removed_point, mut removed_spot, mut removed_dir, mut removed_rect, mut removed_disk): (
        RemovedComponents<PointLight>,
        RemovedComponents<SpotLight>,
        RemovedComponents<DirectionalLight>,
        RemovedComponents<RectLight>,
        RemovedComponents<DiskLight>,
    ),
    live: Query<(), Or<(With<PointLight>, With<SpotLight>, With<DirectionalLight>, With<RectLight>, With<DiskLight>)>>,
    (mut mirror, mut slots): (ResMut<RenderMirror>, ResMut<MirrorSlots>),
    (mut checks, mut visit): (Local<EntityChecks>, Local<Vec<Entity>>),
    (settings, mut stats): (Res<RenderSettings>, ResMut<RenderStats>),
) {
    let EntityChecks { warned, waiting } = &mut *checks;
    let mirror = &mut mirror.0;
    let limit = settings.limits.clamped().lights;
    visit.clear();
    let removed = removed_point.read().chain(removed_spot.read()).chain(removed_dir.read()).chain(removed_rect.read());
    for entity in removed.chain(removed_disk.read()) {
        if live.contains(entity) {
            visit.push(entity); // one kind of light replaced by another
            continue;
        }
        warned.forget(entity);
        waiting.forget(entity);
        if let Some(slot) = slots.lights.remove(&entity) {
            mirror.lights.remove(slot);
            mirror.records_written += 1;
        }
    }
    visit.extend(inserted_point.read().map(|m| m.entity));
    visit.extend(inserted_spot.read().map(|m| m.entity));
    visit.extend(inserted_dir.read().map(|m| m.entity));
    visit.extend(inserted_rect.read().map(|m| m.entity));
    visit.extend(inserted_disk.read().map(|m| m.entity));
    finish_visits(&mut visit, moved.as_deref(), |entity| live.contains(entity), waiting.retry(mirror.lights.len(), limit));
    let mut visited = 0;
    for &entity in visit.iter() {
        let Ok((global, point, spot, dir, rect, disk)) = all.get(entity) else { continue };
        if point.is_none() && spot.is_none() && dir.is_none() && rect.is_none() && disk.is_none() {
            continue; // a moved entity that is not a light
        }
        visited += 1;
        let world = global.compute_matrix();
        let checked = if rect.is_some() || disk.is_some() {
            validate::area_light_record(world, rect, disk)
        } else {
            validate::light_record(world, point, spot, dir)
        };
        let record = match checked {
            Ok((record, clamped)) => {
                warned.report(entity, "light", clamped, "drawn clamped");
                record
            }
            Err(problem) => {
                warned.report(entity, "light", Some(problem), "not drawn until it is fixed");
                waiting.forget(entity);
                if let Some(slot) = slots.lights.remove(&entity) {
                    mirror.lights.remove(slot);
                    mirror.records_written += 1;
                }
                continue;
            }
        };
        if !slots.lights.contains_key(&entity) && !waiting.admit(entity, mirror.lights.len(), limit, "light") {
            continue;
        }
        let slot = SceneMirror::write(&mut mirror.records_written, &mut mirror.lights, slots.lights.get(&entity).copied(), record);
        slots.lights.insert(entity, slot);
    }
    stats.visited.lights = visited;
    stats.over_limit.lights = waiting.len();
}

/// Builds the camera record from the first active camera. The mirror ignores an identical
/// record, so a still camera uploads nothing. A camera whose transform is not finite or not
/// invertible keeps the last good view (one warning); a field of view outside (0, π) or a
/// non-positive near plane is replaced by a default in [`Camera::projection`] (one warning).
///
/// Switching to another camera entity is a camera cut ([`render::SceneMirror::cut_camera`]):
/// temporal anti-aliasing drops its history rather than blend two views.
///
/// The camera record also carries the scene clock for decals fading out at the end of their
/// lifetime; it advances only while one is fading, so that frames in which time merely passes
/// upload nothing.
pub fn extract_camera(
    cameras: Query<(Entity, &Camera, &GlobalTransform)>,
    (settings, time, lifetimes): (Res<RenderSettings>, Res<Time>, Res<DecalLifetimes>),
    mut mirror: ResMut<RenderMirror>,
    (mut warned, mut clock): (Local<WarnOnce<(Entity, bool)>>, Local<f32>),
    mut shown: Local<Option<Entity>>,
) {
    // Decals that landing particles leave fade on the GPU by this clock too.
    if lifetimes.fading() || mirror.0.emitters.leaves_decals() {
        *clock = time.elapsed_secs();
    }
    let Some((entity, camera, global)) = cameras.iter().find(|(_, c, _)| c.active) else {
        return;
    };
    // Another camera is a cut: temporal anti-aliasing starts its history again.
    if shown.replace(entity).is_some_and(|e| e != entity) {
        mirror.0.cut_camera();
    }
    let world = global.compute_matrix();
    let placement = validate::placement_problem(world);
    warned.report((entity, false), "camera", placement, "the last good view is kept");
    let lens_ok = camera.fov_y.is_finite()
        && camera.fov_y > 0.0
        && camera.fov_y < std::f32::consts::PI
        && camera.near.is_finite()
        && camera.near > 0.0
        && camera.exposure.is_finite()
        && camera.exposure >= 0.0;
    let lens = (!lens_ok).then_some("has a field of view outside (0, π), a non-positive near plane or a bad exposure");
    warned.report((entity, true), "camera", lens, "they are clamped or replaced by defaults");
    if placement.is_some() {
        return;
    }
    let exposure = if camera.exposure.is_finite() && camera.exposure >= 0.0 { camera.exposure } else { 1.0 };
    let (w, h) = settings.size;
    let (w, h) = (w.max(1), h.max(1));
    let view = world.inverse();
    let proj = camera.projection(w as f32 / h.max(1) as f32);
    let view_proj = proj * view;
    let mut record = camera_record(view, proj, view_proj, global.translation(), exposure, (w, h), settings.ambient);
    record.time = *clock;
    record.decal_fade = settings
        .decal_distance_fade
        .filter(|f| !(f.start.is_nan() || f.end.is_nan() || f.start < 0.0 || f.end < f.start))
        .map_or(Vec2::INFINITY, |f| Vec2::new(f.start.max(1e-3), f.end.max(f.start).max(1e-3)));
    mirror.0.set_camera(record);
}

fn camera_record(view: Mat4, proj: Mat4, view_proj: Mat4, position: Vec3, exposure: f32, (w, h): (u32, u32), ambient: Vec3) -> GpuCamera {
    GpuCamera {
        view,
        proj,
        view_proj,
        inv_view_proj: view_proj.inverse(),
        position,
        exposure,
        viewport_size: Vec2::new(w as f32, h as f32),
        inv_viewport_size: Vec2::new(1.0 / w as f32, 1.0 / h as f32),
        ambient,
        time: 0.0,
        decal_fade: Vec2::INFINITY,
        // The renderer's to set (temporal anti-aliasing: `SceneMirror::gpu_camera`).
        jitter: Vec2::ZERO,
        taa_frame: 0,
        taa_pad: [0; 3],
        motion_view_proj: view_proj,
        prev_view_proj: view_proj,
    }
}

/// Writes added and modified decal materials into their slots; frees removed ones. A decal whose
/// material changed keeps its slot reference, so only the material record is rewritten.
pub fn extract_decal_materials(
    mut materials: ResMut<Assets<DecalMaterial>>,
    mut mirror: ResMut<RenderMirror>,
    mut slots: ResMut<MirrorSlots>,
) {
    let events: Vec<_> = materials.drain_events().collect();
    let mirror = &mut mirror.0;
    for event in events {
        let handle = event.handle();
        match (&event, materials.get(handle)) {
            (AssetEvent::Added(_) | AssetEvent::Modified(_), Some(material)) => {
                let gpu = gpu_decal_material(material, |h, fallback| h.and_then(|h| slots.textures.get(&h).copied()).unwrap_or(fallback));
                let old = slots.decal_materials.get(&handle).copied();
                let slot = SceneMirror::write(&mut mirror.records_written, &mut mirror.decal_materials, old, gpu);
                slots.decal_materials.insert(handle, slot);
            }
            _ => {
                if let Some(slot) = slots.decal_materials.remove(&handle) {
                    mirror.decal_materials.remove(slot);
                    mirror.records_written += 1;
                }
            }
        }
    }
}

/// Mirrors the decals that were spawned, edited (re-inserted), given or relieved of a lifetime,
/// moved (directly or through a parent) or despawned; unchanged decals are never visited.
///
/// The decals to visit come from lists, not from a scan: [`Inserted`] messages (component hooks on
/// insert), [`TransformChanges::moved`] (transform propagation) and the removal events. So the
/// work is proportional to the decals that changed, and [`RenderStats::visited`] says how many
/// that was. (Without the engine's `TransformPlugin` no moves are listed.)
///
/// The visits run in two halves. The first reads and computes, on every core of the compute task
/// pool: each decal's description, its record and box ([`DecalDesc::prepare`](render::scene::DecalDesc::prepare): an inversion of
/// its transform), its problems and its light, and the slots it already has. The second writes,
/// on this thread, in the visits' order (so slots are given out as a serial run would): for a
/// decal that only moved, two copies into its slot. With 1 % of a million decals moving on the
/// lent machine's 16-core host, the whole extraction took 3.4–3.6 ms with the visits on one
/// thread and 2.1 with the halves; of this system, the list now takes 0.1–0.4 ms to gather, the
/// first half 0.4–0.6 and the second 0.45–0.67 (`docs/experiments/cpu-extraction-change-lists.md`).
/// Asking for the slots a few writes ahead (a prefetch) did not shorten the second half there.
#[allow(clippy::too_many_arguments)]
pub fn extract_decals(
    decals: Query<(&Decal, &GlobalTransform, Option<&ChildOf>)>,
    (mut inserted, moved, lifetimes): (MessageReader<Inserted<Decal>>, Option<Res<TransformChanges>>, Res<DecalLifetimes>),
    mut removed: RemovedComponents<Decal>,
    live: Query<(), With<Decal>>,
    (mut mirror, mut slots): (ResMut<RenderMirror>, ResMut<MirrorSlots>),
    (materials, images): (Res<Assets<DecalMaterial>>, Res<Assets<Image>>),
    (mut checks, mut scratch): (Local<EntityChecks>, Local<DecalScratch>),
    (settings, mut stats): (Res<RenderSettings>, ResMut<RenderStats>),
) {
    let EntityChecks { warned, waiting } = &mut *checks;
    let DecalScratch { visit, found } = &mut *scratch;
    let mirror = &mut mirror.0;
    let limit = settings.limits.clamped().decals;
    let light_limit = settings.limits.clamped().lights;
    for entity in removed.read() {
        if live.contains(entity) {
            continue;
        }
        warned.forget(entity);
        waiting.forget(entity);
        if let Some(slot) = slots.decals.remove(&entity) {
            mirror.decals.remove(slot);
            mirror.records_written += 1;
        }
        set_decal_light(mirror, &mut slots.decal_lights, entity, None, light_limit);
    }
    // One visit per changed decal, however many lists name it.
    visit.clear();
    visit.extend(inserted.read().map(|m| m.entity));
    finish_visits(visit, moved.as_deref(), |entity| live.contains(entity), waiting.retry(mirror.decals.len(), limit));

    // The first half: read and compute, a few chunks a thread, each into its own list.
    let look = |entity: Entity| -> Option<DecalVisit> {
        let (decal, global, parent) = decals.get(entity).ok()?;
        let slot = slots.decals.get(&entity).copied();
        let lit = slots.decal_lights.contains_key(&entity);
        let Some(&material) = slots.decal_materials.get(&decal.material) else {
            return Some(DecalVisit { entity, slot, lit, found: None });
        };
        let world = global.compute_matrix();
        let mut desc = decal_desc(decal, world, material, lifetimes.fade_window(entity));
        // On a skin: its parent's instance slot, when the parent is a posed (skinned) instance.
        let skin = parent.map(|p| p.parent()).filter(|p| slots.posed.contains_key(p)).and_then(|p| slots.instances.get(&p).copied());
        desc.on_skin = skin.filter(|_| decal.on_skin);
        // An invalid decal keeps its slot but lands nowhere: bad parameters give it no receiver
        // layers, and a transform that is not finite or not invertible (DecalDesc::is_valid)
        // an inert record and a point for a box.
        let bad_parameters = validate::decal_problem(decal);
        if bad_parameters.is_some() {
            desc.receivers = 0;
            desc.weight = 1.0;
            desc.opacity = 0.0;
            desc.uv_corners = [glam::Vec2::ZERO; 4];
            desc.angle_fade = None;
        }
        let prepared = desc.prepare();
        let problem = bad_parameters.or((!prepared.is_valid()).then_some("has a transform that is not finite or not invertible"));
        let invalid = problem.is_some();
        // An emitting decal in the world (not on a skin) is a light too.
        let light = (!invalid && desc.on_skin.is_none())
            .then(|| materials.get(decal.material))
            .flatten()
            .and_then(|m| crate::decal::decal_light_radiance(m, decal.opacity, &images))
            .and_then(|radiance| validate::decal_light_record(world, radiance));
        let problem = problem.or((decal.on_skin && desc.on_skin.is_none())
            .then_some("is on_skin but not a child of a skinned mesh instance (placed in the world)"));
        Some(DecalVisit { entity, slot, lit, found: Some(Found { prepared, problem, invalid, light }) })
    };
    let pool = ComputeTaskPool::try_get().filter(|pool| pool.thread_num() > 1 && visit.len() >= 2 * MIN_DECAL_CHUNK);
    let chunk = visit.len().div_ceil(pool.map_or(1, |pool| pool.thread_num() * 4)).max(MIN_DECAL_CHUNK);
    let chunks = visit.len().div_ceil(chunk);
    if found.len() < chunks {
        found.resize_with(chunks, Vec::new);
    }
    let parts = visit.chunks(chunk).zip(found.iter_mut());
    let look_into = |part: &[Entity], out: &mut Vec<DecalVisit>| {
        out.clear();
        out.extend(part.iter().filter_map(|&entity| look(entity)));
    };
    match pool {
        Some(pool) => {
            pool.scope(|scope| {
                let look_into = &look_into;
                for (part, out) in parts {
                    scope.spawn(async move { look_into(part, out) });
                }
            });
        }
        None => parts.for_each(|(part, out)| look_into(part, out)),
    }

    // The second half: write, in the visits' order.
    let mut visited = 0;
    for v in found.iter().take(chunks).flatten() {
        visited += 1;
        let entity = v.entity;
        let Some(Found { prepared, problem, invalid, light }) = v.found else {
            warned.report(entity, "decal", Some("refers to a decal material that does not exist"), "not drawn");
            waiting.forget(entity);
            if let Some(slot) = v.slot {
                slots.decals.remove(&entity);
                mirror.decals.remove(slot);
                mirror.records_written += 1;
            }
            set_decal_light(mirror, &mut slots.decal_lights, entity, None, light_limit);
            continue;
        };
        warned.report(entity, "decal", problem, if invalid { "not drawn until it is fixed" } else { "drawn in the world" });
        if v.slot.is_none() && !waiting.admit(entity, mirror.decals.len(), limit, "decal") {
            set_decal_light(mirror, &mut slots.decal_lights, entity, None, light_limit);
            continue;
        }
        // (Most decals neither emit nor did: no light slot to look up then.)
        if (light.is_some() || v.lit) && !set_decal_light(mirror, &mut slots.decal_lights, entity, light, light_limit) {
            warned.report(entity, "decal's light", Some("finds the light table at its limit"), "the decal glows but lights nothing");
        }
        let written = mirror.decals.write_prepared(v.slot, &prepared);
        mirror.records_written += 1;
        if v.slot.is_none() {
            slots.decals.insert(entity, written);
        }
    }
    stats.visited.decals = visited;
    stats.over_limit.decals = waiting.len();
}

/// The fewest decals a task of [`extract_decals`]' first half takes: fewer cost more to hand
/// out than to look at.
const MIN_DECAL_CHUNK: usize = 256;

/// The lists [`extract_decals`] keeps between frames, so that a warm frame allocates nothing.
#[derive(Default)]
pub struct DecalScratch {
    /// The decals to visit.
    visit: Vec<Entity>,
    /// What the first half found, one list a chunk of `visit`.
    found: Vec<Vec<DecalVisit>>,
}

/// What the first half of [`extract_decals`] found of a visited decal, for the second to write.
struct DecalVisit {
    entity: Entity,
    /// Its record slot, when it has one.
    slot: Option<u32>,
    /// Whether it has a light slot (it emitted light when last written).
    lit: bool,
    /// `None` when its material is not (or no longer) loaded.
    found: Option<Found>,
}

/// What a decal whose material is loaded will be written as.
struct Found {
    prepared: PreparedDecal,
    /// What to warn about (once), if anything.
    problem: Option<&'static str>,
    /// Whether it lands nowhere.
    invalid: bool,
    /// Its light, when it emits one.
    light: Option<GpuLight>,
}

/// Writes, moves or frees the light of an emitting decal (`light`: its record, `None` for no
/// light). Returns false when a new light found the light table at its limit: it is not made
/// (and is tried again only when the decal is next visited: moved or inserted again).
fn set_decal_light(mirror: &mut SceneMirror, slots: &mut EntityHashMap<u32>, entity: Entity, light: Option<GpuLight>, limit: u32) -> bool {
    match (light, slots.get(&entity).copied()) {
        (Some(record), slot) if slot.is_some() || mirror.lights.len() < limit as usize => {
            let written = SceneMirror::write(&mut mirror.records_written, &mut mirror.lights, slot, record);
            slots.insert(entity, written);
        }
        (Some(_), None) => return false,
        (None, Some(slot)) => {
            mirror.lights.remove(slot);
            mirror.records_written += 1;
            slots.remove(&entity);
        }
        _ => {}
    }
    true
}

/// Hands the [`engine::environment::Environment`] resource to the renderer when it changes (or
/// goes: the flat ambient colour then lights the scene). The map's texels are shared, not copied.
pub fn extract_environment(
    environment: Option<Res<engine::environment::Environment>>,
    mut mirror: ResMut<RenderMirror>,
    mut present: Local<bool>,
) {
    use engine::environment::EnvironmentSource as Source;
    match environment {
        Some(env) if env.is_changed() || !*present => {
            let source = match &env.source {
                Source::None => None,
                Source::Sky => Some(render::EnvironmentSource::Sky),
                Source::Map(map) => Some(render::EnvironmentSource::Map(render::EnvironmentMap {
                    width: map.width,
                    height: map.height,
                    texels: map.texels.clone(),
                    projection: match map.projection {
                        engine::environment::Projection::Equirectangular => render::MapProjection::Equirectangular,
                        engine::environment::Projection::CubeFaces => render::MapProjection::CubeFaces,
                    },
                })),
                Source::Uniform(c) => Some(render::EnvironmentSource::Uniform(*c)),
            };
            mirror.0.set_environment(source.map(|source| render::Environment { source, intensity: env.intensity, rotation: env.rotation }));
            *present = true;
        }
        None if *present => {
            mirror.0.set_environment(None);
            *present = false;
        }
        _ => {}
    }
}
