//! The poses of skinned and morphed meshes, as the scene holds them: each skinned source mesh's
//! joint bounds, each posed mesh's latest joint matrices and morph weights, and which of them
//! wait to be skinned. Scene data: the ECS extraction sets poses here (one at a time with
//! [`super::SceneMirror::set_pose`], or a crowd's in chunks on many threads with
//! [`PoseTable::chunks`]), and the skinning pass (`crate::skinning`) takes each frame's jobs from
//! it, its input written straight into staging memory ([`PoseTable::write_input`]).

use std::sync::Arc;

use glam::{Mat4, Vec3, Vec4};

use super::MeshId;
use crate::layout::{GpuJointMatrix, GpuSkinJob, LOD_LEVELS, SKIN_FIRST, SKIN_LEVEL_MASK, SKIN_PREVIOUS_SHIFT};

impl GpuJointMatrix {
    /// The rows of an affine matrix (its last row is dropped).
    pub fn from_mat4(m: Mat4) -> Self {
        let t = m.transpose();
        Self { x: t.x_axis, y: t.y_axis, z: t.z_axis }
    }

    #[cfg(test)]
    fn to_mat4(self) -> Mat4 {
        Mat4::from_cols(self.x, self.y, self.z, Vec4::W).transpose()
    }
}

/// Rest-pose bounds (minimum, maximum corner) of the vertices each joint moves, by joint index,
/// from each vertex's rest position, joints and weights; joints that move nothing have an empty
/// box (minimum above maximum). (CPU picking of posed meshes uses it too.)
pub fn joint_bounds(vertices: impl Iterator<Item = (Vec3, [u16; 4], [f32; 4])>) -> Vec<(Vec3, Vec3)> {
    let mut bounds: Vec<(Vec3, Vec3)> = Vec::new();
    for (p, joints, weights) in vertices {
        for i in 0..4 {
            if weights[i] <= 0.0 {
                continue;
            }
            let j = joints[i] as usize;
            if bounds.len() <= j {
                bounds.resize(j + 1, (Vec3::INFINITY, Vec3::NEG_INFINITY));
            }
            bounds[j] = (bounds[j].0.min(p), bounds[j].1.max(p));
        }
    }
    bounds
}

/// The bounds of a pose: each joint's rest box moved by its matrix, all of them together.
/// `None` when no joint moves anything or a matrix is not finite.
pub fn posed_bounds(joint_bounds: impl IntoIterator<Item = (Vec3, Vec3)>, joints: impl IntoIterator<Item = Mat4>) -> Option<(Vec3, Vec3)> {
    let mut bounds = PoseBounds::default();
    for (rest, m) in joint_bounds.into_iter().zip(joints) {
        bounds.add(rest, &m);
    }
    bounds.finish()
}

/// The bounds of a pose gathered one joint at a time ([`posed_bounds`]), in four-wide
/// registers: setting a crowd's poses moves each joint's box while its matrix is at hand, in
/// the loop that converts the matrix (10,000 foxes' 240,000 joints).
#[derive(Clone, Copy, Debug)]
struct PoseBounds {
    lo: Vec4,
    hi: Vec4,
    /// A moved box was not a number (a four-wide `min` would drop it from `lo` and `hi`).
    nan: bool,
}

impl Default for PoseBounds {
    fn default() -> Self {
        Self { lo: Vec4::INFINITY, hi: Vec4::NEG_INFINITY, nan: false }
    }
}

impl PoseBounds {
    /// Adds a joint's rest box (skipped when empty) moved by its matrix `m` (affine). The box's
    /// centre moves as a point; its half extent along each world axis is the sum of the
    /// matrix's absolute columns scaled by the half sizes.
    #[inline]
    fn add(&mut self, (bmin, bmax): (Vec3, Vec3), m: &Mat4) {
        if bmin.cmpgt(bmax).any() {
            return;
        }
        let (c, h) = ((bmin + bmax) * 0.5, (bmax - bmin) * 0.5);
        let center = m.x_axis * c.x + m.y_axis * c.y + m.z_axis * c.z + m.w_axis;
        let extent = m.x_axis.abs() * h.x + m.y_axis.abs() * h.y + m.z_axis.abs() * h.z;
        self.lo = self.lo.min(center - extent);
        self.hi = self.hi.max(center + extent);
        self.nan |= (center + extent).is_nan();
    }

    /// The bounds gathered: `None` when no joint moved anything or a matrix was not finite.
    fn finish(self) -> Option<(Vec3, Vec3)> {
        let (lo, hi) = (self.lo.truncate(), self.hi.truncate());
        (!self.nan && lo.cmple(hi).all() && lo.is_finite() && hi.is_finite()).then_some((lo, hi))
    }
}

/// Frames a pose stays unchanged before it is skinned whole ("at rest"). Until then the frame
/// after each change skins only the level of detail it is drawn at, as the change did: a
/// character that the animation budget (`engine::animation::AnimationBudget`, periods of up to 4
/// frames by default) poses every few frames never pays for all its vertices, and a pose that
/// stopped for good holds every vertex from then on. Meanwhile it is drawn no finer than its last
/// skinning's level (for at most this many frames, were the camera to come close).
pub const REST_FRAMES: u8 = 8;

/// A posed mesh's joints and skinning state.
#[derive(Clone, Debug)]
struct Pose {
    source: MeshId,
    vertices: u32,
    joints: Vec<GpuJointMatrix>,
    /// Morph weights, one per target of the source.
    weights: Vec<f32>,
    /// Never skinned yet: its first skinning also sets its previous positions.
    fresh: bool,
    /// Set this frame.
    changed: bool,
    /// Frames since the pose last changed ([`REST_FRAMES`] or more: at rest, not listed as
    /// active). The frame after a change it is skinned once more at its level (its previous
    /// positions catch up), and [`REST_FRAMES`] frames after, still unchanged, whole.
    since: u8,
    /// The level of detail whose vertices its last skinning wrote (0: every vertex): the finest
    /// level it can be drawn at ([`PoseTable::drawable_level`]).
    level: u32,
    /// Its next skinning writes every vertex ([`PoseTable::skin_whole`]).
    whole_next: bool,
    /// The [`PoseTable::take_jobs`] call that last found it listed.
    taken: u32,
}

/// A skinned (or morphed) mesh that posed meshes copy.
#[derive(Clone, Debug)]
struct Source {
    /// Per joint, the rest bounds of the vertices it moves (empty without a skin).
    joint_bounds: Arc<[(Vec3, Vec3)]>,
    vertices: u32,
    /// Rest bounds of the whole mesh.
    rest_bounds: (Vec3, Vec3),
    /// Per morph target, the longest position offset: how far a weight of 1 can move a vertex.
    morph_reach: Arc<[f32]>,
    /// Its levels of detail, when a job can skin fewer vertices for them.
    levels: Option<SkinLevels>,
}

/// What skinning needs of a skinned mesh's levels of detail (`crate::lod`) to skin only the
/// vertices of the level a posed copy will be drawn at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinLevels {
    /// Number of coarser levels.
    pub count: u32,
    /// Each coarser level's error (a fraction of the diagonal of the mesh's bounds).
    pub errors: [f32; LOD_LEVELS as usize],
    /// The vertices of each level, level 0 (every vertex) first.
    pub vertices: [u32; LOD_LEVELS as usize + 1],
}

impl SkinLevels {
    /// The coarsest level whose error covers at most `limit` pixels at `scale` pixels per unit
    /// of relative error (0: the mesh itself): `lod_within` of `shaders/include/culling.glsl`.
    pub fn coarsest_within(&self, scale: f32, limit: f32) -> u32 {
        self.errors[..self.count as usize].iter().take_while(|&&e| e * scale <= limit).count() as u32
    }
}

/// Pixels on screen per unit of relative error of a mesh whose world bounds are `[lo, hi]`,
/// seen through `view_proj` over a viewport `height` pixels high: `lod_pixels_per_error` of
/// `shaders/include/culling.glsl`, which the culling pass picks levels of detail with, for the
/// CPU to know which levels the GPU may pick (the bounds' diagonal scaled by the projection at
/// the box's nearest clip w; a box reaching the eye plane gets a huge scale, level 0).
pub fn lod_pixels_per_error(view_proj: Mat4, lo: Vec3, hi: Vec3, height: f32) -> f32 {
    let (r1, r3) = (view_proj.row(1), view_proj.row(3));
    let (c, e) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let w = r3.truncate().dot(c) - r3.truncate().abs().dot(e) + r3.w;
    if w <= 1e-4 {
        return 1e30;
    }
    (hi - lo).length() * 0.5 * height * r1.truncate().length() / w
}

/// What posing needs of a mesh that can be posed ([`crate::scene::SceneMirror::add_mesh`]).
pub(crate) struct SourceDesc {
    pub joint_bounds: Vec<(Vec3, Vec3)>,
    pub vertices: u32,
    pub rest_bounds: (Vec3, Vec3),
    pub morph_reach: Vec<f32>,
    pub levels: Option<SkinLevels>,
}

/// The CPU side of skinning, kept in the [`super::SceneMirror`]: each skinned source mesh's joint
/// bounds and each posed mesh's latest joint matrices.
#[derive(Default)]
pub struct PoseTable {
    /// By mesh id: skinned meshes (sources).
    sources: Vec<Option<Source>>,
    /// By mesh id: the pose of a posed mesh.
    poses: Vec<Option<Pose>>,
    /// Posed meshes set this frame, catching up, or still short of [`REST_FRAMES`] (a mesh id
    /// freed and posed again may be listed twice: [`PoseTable::take_jobs`] drops the second).
    active: Vec<MeshId>,
    /// [`PoseTable::take_jobs`] calls so far (what `Pose::taken` is stamped with).
    takes: u32,
    /// Posed meshes (the `Some` entries of `poses`).
    posed: u32,
    /// This frame's jobs (posed meshes skinned), once [`PoseTable::take_jobs`] has run.
    jobs: Vec<MeshId>,
    /// Their vertices.
    job_vertices: u64,
    /// Their joint matrices (the morph weights follow them).
    palette_len: u32,
    /// Their morph weights.
    weight_len: u32,
    /// Per job: its header, as the skinning pass reads it (its pose's first joint matrix and
    /// morph weight in this frame's input, whether it is the pose's first skinning).
    headers: Vec<GpuSkinJob>,
}

impl PoseTable {
    /// Notes a source mesh that can be posed (skinned or morphed), or forgets one (`None`).
    pub(crate) fn set_source(&mut self, id: MeshId, desc: Option<SourceDesc>) {
        let slot = id.0 as usize;
        if self.sources.len() <= slot {
            self.sources.resize(slot + 1, None);
        }
        self.sources[slot] = desc.map(|d| Source {
            joint_bounds: d.joint_bounds.into(),
            vertices: d.vertices,
            rest_bounds: d.rest_bounds,
            morph_reach: d.morph_reach.into(),
            levels: d.levels,
        });
    }

    /// Whether mesh `id` can be posed: it has a skin or morph targets.
    pub fn can_pose(&self, id: MeshId) -> bool {
        self.sources.get(id.0 as usize).is_some_and(Option::is_some)
    }

    /// Whether some mesh is posed.
    pub fn any_posed(&self) -> bool {
        self.posed > 0
    }

    /// Whether mesh `id` is a posed mesh.
    pub fn is_posed(&self, id: MeshId) -> bool {
        self.poses.get(id.0 as usize).is_some_and(Option::is_some)
    }

    /// Whether mesh `id` has a skin (joints move it).
    pub fn is_skinned(&self, id: MeshId) -> bool {
        self.joint_count(id) > 0
    }

    /// The number of morph targets of mesh `id` (0 for a mesh that cannot be posed).
    pub fn morph_targets(&self, id: MeshId) -> usize {
        self.sources.get(id.0 as usize).and_then(Option::as_ref).map_or(0, |s| s.morph_reach.len())
    }

    /// The number of joints mesh `id`'s skin refers to (0 for a mesh without a skin).
    pub fn joint_count(&self, id: MeshId) -> usize {
        self.sources.get(id.0 as usize).and_then(Option::as_ref).map_or(0, |s| s.joint_bounds.len())
    }

    /// Starts posing `source` as `posed`; false when `source` has no skin.
    pub(crate) fn add(&mut self, posed: MeshId, source: MeshId) -> bool {
        let Some(vertices) = self.sources.get(source.0 as usize).and_then(Option::as_ref).map(|s| s.vertices) else { return false };
        let slot = posed.0 as usize;
        if self.poses.len() <= slot {
            self.poses.resize(slot + 1, None);
        }
        self.posed += u32::from(self.poses[slot].is_none());
        self.poses[slot] = Some(Pose {
            source,
            vertices,
            joints: Vec::new(),
            weights: Vec::new(),
            fresh: true,
            changed: false,
            since: REST_FRAMES,
            level: 0,
            whole_next: false,
            taken: 0,
        });
        true
    }

    /// Forgets mesh `id` as a source and as a posed mesh.
    pub(crate) fn remove(&mut self, id: MeshId) {
        if let Some(p) = self.poses.get_mut(id.0 as usize) {
            self.posed -= u32::from(p.take().is_some());
        }
        if let Some(s) = self.sources.get_mut(id.0 as usize) {
            *s = None;
        }
    }

    /// Sets a posed mesh's joint matrices (joint's world × inverse bind matrix, in the posed
    /// mesh's object space; ignored for a mesh without a skin) and morph weights (missing ones
    /// are 0), and returns the pose's bounds (`None` when they cannot be known); `None` (nothing
    /// set) when `posed` is not a posed mesh. [`PoseTable::chunks`] sets many on many threads.
    pub(crate) fn set(&mut self, posed: MeshId, joints: impl IntoIterator<Item = Mat4>, weights: &[f32]) -> Option<Option<(Vec3, Vec3)>> {
        let pose = self.poses.get_mut(posed.0 as usize)?.as_mut()?;
        let source = self.sources.get(pose.source.0 as usize).and_then(Option::as_ref)?;
        let (bounds, newly_active) = set_pose(pose, source, joints, weights);
        if newly_active {
            self.active.push(posed);
        }
        Some(bounds)
    }

    /// Splits a batch of poses to set into about `parts` chunks that can be set on separate
    /// threads ([`PoseChunk::set`]): each chunk holds its poses alone. The batch is sorted by
    /// mesh first; [`crate::scene::SceneMirror::finish_poses`] completes it once every chunk is
    /// set. Allocates nothing.
    pub fn chunks<'p, T>(&'p mut self, batch: &'p mut [PoseSet<T>], parts: usize) -> PoseChunks<'p, T> {
        batch.sort_unstable_by_key(|s| s.mesh.0);
        PoseChunks { poses: &mut self.poses, first: 0, sources: &self.sources, batch, parts: parts.max(1) }
    }

    /// Notes the poses a batch set ([`PoseTable::chunks`]) as waiting to be skinned.
    pub(crate) fn finish<T>(&mut self, batch: &[PoseSet<T>]) {
        self.active.extend(batch.iter().filter(|s| s.newly_active).map(|s| s.mesh));
    }

    /// Collects this frame's skinning jobs and moves every pose a frame on: what changed catches
    /// up next frame, and what has not changed for [`REST_FRAMES`] frames is skinned whole and
    /// rests. Returns the most vertices of a job. The jobs' input is
    /// written straight into the upload's staging memory ([`PoseTable::write_input`]).
    pub(crate) fn take_jobs(&mut self) -> u32 {
        // Each listed pose once.
        self.takes = self.takes.wrapping_add(1);
        let (takes, poses) = (self.takes, &mut self.poses);
        self.active.retain(|&id| match poses.get_mut(id.0 as usize) {
            Some(Some(pose)) if pose.taken != takes => {
                pose.taken = takes;
                true
            }
            _ => false,
        });
        self.jobs.clear();
        self.job_vertices = 0;
        let mut most = 0;
        let mut joints = 0;
        let mut weights = 0;
        for &id in &self.active {
            let Some(Some(pose)) = self.poses.get(id.0 as usize) else { continue };
            if pose.vertices == 0 || (pose.joints.is_empty() && pose.weights.is_empty()) {
                continue;
            }
            // Changed, catching up the frame after, or come to rest: anything else waits.
            if !(pose.changed || pose.since == 0 || pose.since + 1 == REST_FRAMES) {
                continue;
            }
            most = most.max(pose.vertices);
            self.job_vertices += pose.vertices as u64;
            self.jobs.push(id);
            joints += pose.joints.len();
            weights += pose.weights.len();
        }
        self.palette_len = joints as u32;
        self.weight_len = weights as u32;
        // Each job's `first` flag is read now, before the poses move on.
        self.headers.clear();
        let (mut palette, mut first_weight) = (0, 0);
        for &id in &self.jobs {
            let pose = self.poses[id.0 as usize].as_ref().expect("listed above");
            let levels = if pose.fresh { SKIN_FIRST } else { pose.level << SKIN_PREVIOUS_SHIFT };
            self.headers.push(GpuSkinJob { mesh: id.0, palette, levels, weights: first_weight });
            palette += pose.joints.len() as u32;
            first_weight += pose.weights.len() as u32;
        }
        let mut active = std::mem::take(&mut self.active);
        active.retain(|&id| {
            let Some(Some(pose)) = self.poses.get_mut(id.0 as usize) else { return false };
            pose.fresh &= pose.joints.is_empty() && pose.weights.is_empty();
            pose.since = if std::mem::take(&mut pose.changed) { 0 } else { pose.since.saturating_add(1) };
            pose.since < REST_FRAMES
        });
        self.active = active;
        most
    }

    /// Joint matrices of this frame's jobs (the morph weights follow them in the input).
    pub fn palette_len(&self) -> u32 {
        self.palette_len
    }

    /// 32-bit words of this frame's skinning input: the `GpuSkinJob`s, then the joint matrices,
    /// then the morph weights they point at.
    pub fn input_words(&self) -> usize {
        self.jobs.len() * std::mem::size_of::<GpuSkinJob>() / 4
            + self.palette_len as usize * std::mem::size_of::<GpuJointMatrix>() / 4
            + self.weight_len as usize
    }

    /// Writes this frame's skinning input ([`PoseTable::input_words`] words) into `dst`, the
    /// staging memory the upload copies from: the poses' matrices are copied once, here, on
    /// every core of the process's compute task pool (`bevy_tasks`, which the ECS app that
    /// drives the renderer starts; on the calling thread alone without one).
    pub fn write_input(&self, dst: &mut [u8]) {
        // `dst` is 16-byte aligned (staging memory), as are the matrices after the 16-byte jobs.
        let (headers, rest) = dst.split_at_mut(self.jobs.len() * std::mem::size_of::<GpuSkinJob>());
        let (palette, weights) = rest.split_at_mut(self.palette_len as usize * std::mem::size_of::<GpuJointMatrix>());
        bytemuck::cast_slice_mut::<u8, GpuSkinJob>(headers).copy_from_slice(&self.headers);
        let weights: &mut [f32] = bytemuck::cast_slice_mut(weights);
        for (header, &id) in self.headers.iter().zip(&self.jobs) {
            let pose = self.poses[id.0 as usize].as_ref().expect("a job's pose");
            let first = header.weights as usize;
            weights[first..first + pose.weights.len()].copy_from_slice(&pose.weights);
        }
        let palette: &mut [GpuJointMatrix] = bytemuck::cast_slice_mut(palette);
        // Jobs in runs of at least this many share a task.
        const RUN: usize = 256;
        let pool = bevy_tasks::ComputeTaskPool::try_get().filter(|pool| pool.thread_num() > 1 && self.jobs.len() >= 2 * RUN);
        let Some(pool) = pool else {
            self.write_matrices(0..self.jobs.len(), palette);
            return;
        };
        let run = self.jobs.len().div_ceil(pool.thread_num()).max(RUN);
        pool.scope(|scope| {
            let mut palette = palette;
            for start in (0..self.jobs.len()).step_by(run) {
                let end = (start + run).min(self.jobs.len());
                let matrices = self.headers.get(end).map_or(self.palette_len, |h| h.palette) - self.headers[start].palette;
                let (part, rest) = std::mem::take(&mut palette).split_at_mut(matrices as usize);
                palette = rest;
                scope.spawn(async move { self.write_matrices(start..end, part) });
            }
        });
    }

    /// Copies the joint matrices of the jobs `jobs` (consecutive) into `palette`, their place in
    /// this frame's input.
    fn write_matrices(&self, jobs: std::ops::Range<usize>, palette: &mut [GpuJointMatrix]) {
        let mut at = 0;
        for &id in &self.jobs[jobs] {
            let joints = &self.poses[id.0 as usize].as_ref().expect("a job's pose").joints;
            palette[at..at + joints.len()].copy_from_slice(joints);
            at += joints.len();
        }
    }

    /// The posed meshes skinned this frame (once the frame's jobs were taken).
    pub fn jobs(&self) -> &[MeshId] {
        &self.jobs
    }

    /// The vertices skinned this frame.
    pub fn job_vertices(&self) -> u64 {
        self.job_vertices
    }

    /// Whether no pose waits to be skinned.
    pub fn is_clean(&self) -> bool {
        self.active.is_empty()
    }

    /// Whether every vertex of posed mesh `id` holds its current pose by the end of this frame's
    /// skinning, so that a structure refit from it now is the pose's: its last skinning wrote
    /// every vertex, or it is skinned this frame (a job, which a refit makes whole). True for
    /// every mesh that is not posed.
    pub fn whole_by_now(&self, id: MeshId) -> bool {
        let Some(Some(pose)) = self.poses.get(id.0 as usize) else { return true };
        pose.level == 0 || (pose.taken == self.takes && (pose.since <= 1 || pose.since == REST_FRAMES))
    }

    /// Skins posed mesh `id` whole next frame, in its current pose (for a structure woken from
    /// dormancy that must be refit from it while its last skinning wrote its level of detail
    /// alone).
    pub fn skin_whole(&mut self, id: MeshId) {
        let Some(Some(pose)) = self.poses.get_mut(id.0 as usize) else { return };
        if !pose.changed && pose.since >= REST_FRAMES {
            self.active.push(id);
        }
        pose.changed = true;
        pose.whole_next = true;
    }

    /// The finest level of detail posed mesh `id` can be drawn at: its last skinning wrote the
    /// vertices of that level and the coarser ones only (0 for every other mesh).
    pub fn drawable_level(&self, id: MeshId) -> u32 {
        self.poses.get(id.0 as usize).and_then(Option::as_ref).map_or(0, |p| p.level)
    }

    /// Sets the level of detail whose vertices each of this frame's jobs skins (once the jobs
    /// were taken): `choose(posed mesh, its source's levels)` for a job that may skin fewer
    /// vertices, and 0 (every vertex) for the first skinning of a pose, for its skinning once it
    /// has been still for [`REST_FRAMES`] frames (so that a pose at rest holds every vertex), and
    /// after [`PoseTable::skin_whole`]. Counts the
    /// vertices skinned ([`PoseTable::job_vertices`]) and lists the posed meshes whose level
    /// changed in `changed` (their culling records name it). Returns the most vertices a job
    /// skins.
    pub fn set_levels(&mut self, mut choose: impl FnMut(MeshId, &SkinLevels) -> u32, changed: &mut Vec<MeshId>) -> u32 {
        self.job_vertices = 0;
        let mut most = 0;
        for (header, &id) in self.headers.iter_mut().zip(&self.jobs) {
            let Some(pose) = self.poses.get_mut(id.0 as usize).and_then(Option::as_mut) else { continue };
            let source = self.sources.get(pose.source.0 as usize).and_then(Option::as_ref);
            // `since` was moved on by `take_jobs`: 0 for a pose changed this frame, 1 for its
            // catch-up the frame after, `REST_FRAMES` for its whole skinning at rest.
            let partial = header.levels & SKIN_FIRST == 0 && pose.since <= 1 && !std::mem::take(&mut pose.whole_next);
            let (level, vertices) = match source.and_then(|s| s.levels.as_ref()).filter(|_| partial) {
                Some(levels) => {
                    let level = choose(id, levels).min(levels.count);
                    (level, levels.vertices[level as usize])
                }
                None => (0, pose.vertices),
            };
            header.levels = (header.levels & !SKIN_LEVEL_MASK) | level;
            self.job_vertices += vertices as u64;
            most = most.max(vertices);
            if pose.level != level {
                pose.level = level;
                changed.push(id);
            }
        }
        most
    }
}

/// Sets `pose` (of `source`) to `joints` and `weights` ([`PoseTable::set`]); returns the pose's
/// bounds and whether it was not waiting to be skinned before.
fn set_pose(pose: &mut Pose, source: &Source, joints: impl IntoIterator<Item = Mat4>, weights: &[f32]) -> (Option<(Vec3, Vec3)>, bool) {
    pose.weights.clear();
    pose.weights.extend((0..source.morph_reach.len()).map(|t| weights.get(t).copied().filter(|w| w.is_finite()).unwrap_or(0.0)));
    let newly_active = !pose.changed && pose.since >= REST_FRAMES;
    pose.changed = true;
    // Morph targets move vertices by at most their reach times their weight: the boxes grow
    // by that before the joints move them.
    let reach: f32 = pose.weights.iter().zip(source.morph_reach.iter()).map(|(w, r)| w.abs() * r).sum();
    let grow = |(lo, hi): (Vec3, Vec3)| if lo.cmpgt(hi).any() { (lo, hi) } else { (lo - Vec3::splat(reach), hi + Vec3::splat(reach)) };
    pose.joints.clear();
    if source.joint_bounds.is_empty() {
        return (Some(grow(source.rest_bounds)), newly_active);
    }
    // One pass over the joints: each converted and its box moved while it is at hand.
    let mut bounds = PoseBounds::default();
    pose.joints.extend(joints.into_iter().enumerate().map(|(j, m)| {
        if let Some(&rest) = source.joint_bounds.get(j) {
            bounds.add(grow(rest), &m);
        }
        GpuJointMatrix::from_mat4(m)
    }));
    (bounds.finish(), newly_active)
}

/// One pose of a batch set on many threads at once ([`PoseTable::chunks`]): the posed mesh, the
/// caller's item it comes from (an entity, an index), and what setting it found.
#[derive(Clone, Copy, Debug)]
pub struct PoseSet<T> {
    /// The posed mesh.
    pub mesh: MeshId,
    /// The caller's item, handed back to [`PoseChunk::set`]'s closure.
    pub item: T,
    /// Once set: the pose's bounds (`None` when they cannot be known); `None` when `mesh` is
    /// not a posed mesh.
    outcome: Option<Option<(Vec3, Vec3)>>,
    newly_active: bool,
}

impl<T> PoseSet<T> {
    /// The pose of `mesh` that `item` gives.
    pub fn new(mesh: MeshId, item: T) -> Self {
        Self { mesh, item, outcome: None, newly_active: false }
    }

    /// Whether the pose was set (the mesh is a posed mesh and its chunk was set).
    pub fn was_set(&self) -> bool {
        self.outcome.is_some()
    }

    /// The bounds the pose was set to (`None` when not set or not known).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.outcome.flatten()
    }
}

/// The chunks of a batch of poses ([`PoseTable::chunks`]), each with the poses it sets.
pub struct PoseChunks<'p, T> {
    poses: &'p mut [Option<Pose>],
    /// The mesh id of `poses[0]`.
    first: usize,
    sources: &'p [Option<Source>],
    batch: &'p mut [PoseSet<T>],
    parts: usize,
}

impl<'p, T> Iterator for PoseChunks<'p, T> {
    type Item = PoseChunk<'p, T>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.batch.is_empty() {
            return None;
        }
        // An even share of what is left, widened to keep one mesh's sets in one chunk.
        let mut take = self.batch.len().div_ceil(self.parts);
        let last = self.batch[take - 1].mesh.0;
        while take < self.batch.len() && self.batch[take].mesh.0 == last {
            take += 1;
        }
        self.parts = self.parts.saturating_sub(1).max(1);
        let (batch, rest) = std::mem::take(&mut self.batch).split_at_mut(take);
        self.batch = rest;
        let split = (last as usize + 1).saturating_sub(self.first).min(self.poses.len());
        let (poses, rest) = std::mem::take(&mut self.poses).split_at_mut(split);
        self.poses = rest;
        let first = self.first;
        self.first += split;
        Some(PoseChunk { poses, first, sources: self.sources, batch })
    }
}

/// Poses of a batch that one thread sets ([`PoseChunks`]).
pub struct PoseChunk<'p, T> {
    poses: &'p mut [Option<Pose>],
    first: usize,
    sources: &'p [Option<Source>],
    batch: &'p mut [PoseSet<T>],
}

impl<T> PoseChunk<'_, T> {
    /// Sets each pose of the chunk to the joint matrices and morph weights `pose_of` gives for
    /// its item (as [`crate::scene::SceneMirror::set_pose`] does).
    pub fn set<'j>(self, mut pose_of: impl FnMut(&T) -> (&'j [Mat4], &'j [f32])) {
        // Each pose's matrices are asked for one pose ahead: they were written by the engine
        // elsewhere (a crowd's 15 MB, out of the caches by now), and reading them had been
        // most of this loop's time, waiting on memory.
        let mut ahead = self.batch.first().map(|entry| pose_of(&entry.item));
        for i in 0..self.batch.len() {
            let (joints, weights) = ahead.take().expect("looked up one pose ahead");
            ahead = self.batch.get(i + 1).map(|entry| pose_of(&entry.item));
            if let Some((next, _)) = ahead {
                prefetch(next);
            }
            let entry = &mut self.batch[i];
            let Some(Some(pose)) = (entry.mesh.0 as usize).checked_sub(self.first).and_then(|i| self.poses.get_mut(i)) else { continue };
            let Some(source) = self.sources.get(pose.source.0 as usize).and_then(Option::as_ref) else { continue };
            let (bounds, newly_active) = set_pose(pose, source, joints.iter().copied(), weights);
            entry.outcome = Some(bounds);
            entry.newly_active = newly_active;
        }
    }
}

/// Asks the processor to bring `data` into its caches, without waiting for it (a hint; nothing
/// on other processors).
#[inline]
fn prefetch<T>(data: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let start = data.as_ptr().cast::<i8>();
        for offset in (0..std::mem::size_of_val(data)).step_by(64) {
            // SAFETY: a prefetch never faults and reads nothing into the program; every
            // address is inside `data`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = data;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::GpuSkinVertex;

    #[test]
    fn pose_bounds_follow_the_joints() {
        let positions = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        let skin = [
            GpuSkinVertex::new([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
            GpuSkinVertex::new([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]),
            GpuSkinVertex::new([1, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        ];
        let bounds = joint_bounds(positions.into_iter().zip(&skin).map(|(p, s)| (p, s.joints(), s.weights())));
        assert_eq!(bounds, vec![(Vec3::ZERO, Vec3::Y), (Vec3::Y, Vec3::new(0.0, 2.0, 0.0))]);
        let moved = [GpuJointMatrix::from_mat4(Mat4::IDENTITY), GpuJointMatrix::from_mat4(Mat4::from_translation(Vec3::X * 3.0))];
        assert_eq!(posed_bounds(bounds.iter().copied(), moved.map(|m| m.to_mat4())), Some((Vec3::ZERO, Vec3::new(3.0, 2.0, 0.0))));
        // A quarter turn about z takes the second joint's box (y from 1 to 2) to x from -2 to -1.
        let turned =
            posed_bounds(bounds.iter().copied(), [Mat4::IDENTITY, Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2)]).expect("bounds");
        assert!(
            turned.0.abs_diff_eq(Vec3::new(-2.0, 0.0, 0.0), 1e-6) && turned.1.abs_diff_eq(Vec3::new(0.0, 1.0, 0.0), 1e-6),
            "{turned:?}"
        );
        // A matrix that is not a number, first or last, leaves the bounds unknown.
        let nan = Mat4::from_translation(Vec3::NAN);
        assert_eq!(posed_bounds(bounds.iter().copied(), [nan, Mat4::IDENTITY]), None);
        assert_eq!(posed_bounds(bounds.iter().copied(), [Mat4::IDENTITY, nan]), None);
    }

    #[test]
    fn a_pose_is_skinned_when_set_and_once_more_to_settle() {
        let mut t = PoseTable::default();
        let desc = SourceDesc {
            joint_bounds: vec![(Vec3::ZERO, Vec3::ONE)],
            vertices: 10,
            rest_bounds: (Vec3::ZERO, Vec3::ONE),
            morph_reach: vec![],
            levels: None,
        };
        t.set_source(MeshId(0), Some(desc));
        assert!(t.add(MeshId(1), MeshId(0)));
        assert!(!t.add(MeshId(2), MeshId(5)), "no such skinned mesh");
        assert_eq!(t.take_jobs(), 0, "never posed: nothing to skin");
        t.set(MeshId(1), [Mat4::IDENTITY], &[]).expect("a posed mesh");
        assert_eq!(t.take_jobs(), 10);
        assert_eq!(t.jobs(), &[MeshId(1)]);
        let words = input(&t);
        assert_eq!(words.len(), 4 + 12, "one job and one joint matrix");
        assert_eq!(words[2], SKIN_FIRST, "the first skinning sets the previous positions too");
        t.take_jobs();
        assert_eq!(t.jobs(), &[MeshId(1)], "settles once");
        assert_eq!(input(&t)[2], 0);
        for _ in 2..REST_FRAMES {
            t.take_jobs();
            assert!(t.jobs().is_empty() && input(&t).is_empty(), "waits, skinning nothing");
        }
        t.take_jobs();
        assert_eq!(t.jobs(), &[MeshId(1)], "skinned whole at rest");
        t.take_jobs();
        assert!(t.jobs().is_empty() && input(&t).is_empty() && t.is_clean(), "then rests");
    }

    /// The skinning table of a mesh's levels: each level's list holds the vertices its triangles
    /// (and a coarser level's) use, and each vertex's byte says its coarsest level.
    #[test]
    fn a_levels_skin_table_lists_its_vertices_and_each_vertexs_coarsest_level() {
        use crate::scene::MeshLods;
        let mut counts = [0; LOD_LEVELS as usize];
        (counts[0], counts[1]) = (6, 3);
        let lods = MeshLods { indices: vec![0, 2, 4, 2, 3, 4, 0, 2, 4], counts, errors: [0.1, 0.2, 0.0, 0.0] };
        let table = lods.skin_table(6);
        let header = 2 * LOD_LEVELS as usize;
        let level = |v: usize| (table[header + v / 4] >> (8 * (v % 4))) & 0xFF;
        assert_eq!((0..6).map(level).collect::<Vec<_>>(), [2, 0, 2, 1, 2, 0]);
        let list = |l: usize| &table[table[l - 1] as usize..][..table[LOD_LEVELS as usize + l - 1] as usize];
        assert_eq!(list(1), [0, 2, 3, 4]);
        assert_eq!(list(2), [0, 2, 4]);
        assert_eq!(table.len(), header + 2 + 4 + 3);
        assert!(MeshLods::default().skin_table(6).is_empty(), "no levels, no table");
    }

    /// A far pose that keeps changing skins the vertices of the level it is chosen, says the
    /// level of its last skinning, catches up at that level the frame after it stops changing,
    /// and [`REST_FRAMES`] frames later is skinned whole; the first skinning is whole too, and
    /// the vertices counted are those skinned.
    #[test]
    fn a_moving_pose_skins_its_level_only_and_rests_with_every_vertex() {
        let mut t = PoseTable::default();
        let levels = SkinLevels { count: 2, errors: [0.01, 0.05, 0.0, 0.0], vertices: [10, 6, 3, 0, 0] };
        let desc = SourceDesc {
            joint_bounds: vec![(Vec3::ZERO, Vec3::ONE)],
            vertices: 10,
            rest_bounds: (Vec3::ZERO, Vec3::ONE),
            morph_reach: vec![],
            levels: Some(levels),
        };
        t.set_source(MeshId(0), Some(desc));
        assert!(t.add(MeshId(1), MeshId(0)));
        let mut changed = Vec::new();
        let mut frame = |t: &mut PoseTable, set: bool, choose: u32| {
            if set {
                t.set(MeshId(1), [Mat4::IDENTITY], &[]).expect("a posed mesh");
            }
            t.take_jobs();
            changed.clear();
            t.set_levels(|_, l| if l == &levels { choose } else { 0 }, &mut changed);
            let words = input(t);
            (words.get(2).copied(), t.job_vertices(), t.drawable_level(MeshId(1)), changed.len())
        };
        assert_eq!(frame(&mut t, true, 2), (Some(SKIN_FIRST), 10, 0, 0), "the first skinning is whole");
        assert_eq!(frame(&mut t, true, 2), (Some(2), 3, 2, 1), "then the chosen level's vertices");
        assert_eq!(frame(&mut t, true, 1), (Some(1 | 2 << SKIN_PREVIOUS_SHIFT), 6, 1, 1), "a finer level knows the last one");
        assert_eq!(frame(&mut t, true, 7), (Some(2 | 1 << SKIN_PREVIOUS_SHIFT), 3, 2, 1), "no coarser than the mesh's last level");
        assert_eq!(frame(&mut t, false, 2), (Some(2 | 2 << SKIN_PREVIOUS_SHIFT), 3, 2, 0), "the frame after catches up at its level");
        for f in 2..REST_FRAMES {
            assert_eq!(frame(&mut t, false, 2), (None, 0, 2, 0), "{f} frames unchanged: nothing to skin yet");
        }
        assert_eq!(frame(&mut t, false, 2), (Some(2 << SKIN_PREVIOUS_SHIFT), 10, 0, 1), "at rest it is skinned whole");
        assert_eq!(frame(&mut t, false, 2), (None, 0, 0, 0), "and the pose rests whole");
        // A pose set every few frames (the animation budget) never comes to rest.
        for f in 0..12 {
            let (_, vertices, level, _) = frame(&mut t, f % 4 == 0, 2);
            assert!(f == 0 || vertices <= 3, "frame {f}: {vertices} vertices skinned at level {level}");
        }
    }

    /// A pose partly skinned (its level of detail) is not whole until `skin_whole` has it skinned
    /// whole the next frame, in the same pose; a mesh id freed and posed again while still listed
    /// is skinned once a frame.
    #[test]
    fn a_partly_skinned_pose_is_skinned_whole_on_request_and_a_reused_id_once() {
        let mut t = PoseTable::default();
        let levels = SkinLevels { count: 2, errors: [0.01, 0.05, 0.0, 0.0], vertices: [10, 6, 3, 0, 0] };
        let desc = || SourceDesc {
            joint_bounds: vec![(Vec3::ZERO, Vec3::ONE)],
            vertices: 10,
            rest_bounds: (Vec3::ZERO, Vec3::ONE),
            morph_reach: vec![],
            levels: Some(levels),
        };
        t.set_source(MeshId(0), Some(desc()));
        assert!(t.add(MeshId(1), MeshId(0)));
        let frame = |t: &mut PoseTable, set: bool| {
            if set {
                t.set(MeshId(1), [Mat4::IDENTITY], &[]).expect("a posed mesh");
            }
            t.take_jobs();
            t.set_levels(|_, _| 2, &mut Vec::new());
            (t.jobs().len(), t.job_vertices())
        };
        assert_eq!(frame(&mut t, true), (1, 10), "the first skinning is whole");
        assert_eq!(frame(&mut t, true), (1, 3), "then its level");
        assert!(t.whole_by_now(MeshId(1)), "skinned this frame");
        assert_eq!(frame(&mut t, false), (1, 3), "the catch-up, at its level");
        assert_eq!(frame(&mut t, false), (0, 0));
        assert!(!t.whole_by_now(MeshId(1)), "its other vertices hold an older pose");
        t.skin_whole(MeshId(1));
        assert_eq!(frame(&mut t, false), (1, 10), "skinned whole on request");
        assert!(t.whole_by_now(MeshId(1)));
        assert_eq!(frame(&mut t, false), (1, 3), "caught up at its level, the same pose");
        assert!(t.whole_by_now(MeshId(1)));
        // Freed and posed again while listed: one job.
        t.set(MeshId(1), [Mat4::IDENTITY], &[]).expect("a posed mesh");
        t.remove(MeshId(1));
        t.set_source(MeshId(0), Some(desc()));
        assert!(t.add(MeshId(1), MeshId(0)));
        t.set(MeshId(1), [Mat4::IDENTITY], &[]).expect("a posed mesh");
        assert_eq!(frame(&mut t, false), (1, 10), "one job, the new pose's first");
    }

    /// This frame's skinning input as the upload writes it, in 16-byte aligned memory.
    fn input(t: &PoseTable) -> Vec<u32> {
        let mut memory = vec![Vec4::ZERO; t.input_words().div_ceil(4)];
        t.write_input(&mut bytemuck::cast_slice_mut(&mut memory)[..t.input_words() * 4]);
        bytemuck::cast_slice(&memory)[..t.input_words()].to_vec()
    }

    /// A table of `sources` skinned meshes of `joints` joints (ids 0..) and `posed` posed copies
    /// of them (ids after), one of which is never posed.
    fn table(sources: u32, joints: usize, posed: u32) -> PoseTable {
        let mut t = PoseTable::default();
        for s in 0..sources {
            let desc = SourceDesc {
                joint_bounds: (0..joints).map(|j| (Vec3::splat(j as f32), Vec3::splat(j as f32 + 1.0))).collect(),
                vertices: 8,
                rest_bounds: (Vec3::ZERO, Vec3::splat(joints as f32)),
                morph_reach: vec![0.5],
                levels: None,
            };
            t.set_source(MeshId(s), Some(desc));
        }
        for p in 0..posed {
            assert!(t.add(MeshId(sources + p), MeshId(p % sources)));
        }
        t
    }

    #[test]
    fn a_crowds_input_written_on_many_threads_equals_the_input_written_on_one() {
        let (sources, joints, posed) = (2, 24, 1_500);
        let mut t = table(sources, joints, posed);
        for p in 0..posed {
            let matrices = (0..joints).map(|j| Mat4::from_translation(Vec3::new(p as f32, j as f32, 0.5)));
            t.set(MeshId(sources + p), matrices, &[p as f32 * 1e-3]).expect("a posed mesh");
        }
        t.take_jobs();
        assert_eq!(t.jobs().len(), posed as usize);
        // On the calling thread alone: the reference.
        let mut one = vec![Vec4::ZERO; t.input_words().div_ceil(4)];
        let headers = t.jobs().len() * std::mem::size_of::<GpuSkinJob>();
        let palette = t.palette_len as usize * std::mem::size_of::<GpuJointMatrix>();
        {
            let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut one);
            bytes[..headers].copy_from_slice(bytemuck::cast_slice(&t.headers));
            t.write_matrices(0..t.jobs().len(), bytemuck::cast_slice_mut(&mut bytes[headers..headers + palette]));
        }
        // On a pool of four threads.
        bevy_tasks::ComputeTaskPool::get_or_init(|| bevy_tasks::TaskPoolBuilder::new().num_threads(4).build());
        let many = input(&t);
        let one: &[u32] = bytemuck::cast_slice(&one);
        assert_eq!(&many[..(headers + palette) / 4], &one[..(headers + palette) / 4], "the jobs and every joint matrix");
        let weights: &[f32] = bytemuck::cast_slice(&many[(headers + palette) / 4..]);
        assert_eq!(weights.len(), posed as usize);
        assert!(weights.iter().enumerate().all(|(p, &w)| w == p as f32 * 1e-3), "each pose's morph weight in job order");
    }

    #[test]
    fn poses_set_in_chunks_equal_poses_set_one_by_one() {
        let (sources, joints, posed) = (3, 5, 40);
        let pose = |i: u32| {
            let joints: Vec<Mat4> = (0..joints).map(|j| Mat4::from_translation(Vec3::new(i as f32, j as f32, 1.0))).collect();
            (joints, vec![i as f32 * 0.1])
        };
        let poses: Vec<_> = (0..posed + 2).map(pose).collect();
        // Every other posed mesh, out of order, plus a source and an unknown mesh (not posed).
        let mut ids: Vec<u32> = (0..posed).step_by(2).rev().map(|p| sources + p).collect();
        ids.extend([1, sources + posed + 7]);
        let mut one_by_one = table(sources, joints, posed);
        let serial: Vec<_> = ids
            .iter()
            .map(|&id| {
                let (joints, weights) = &poses[id as usize % poses.len()];
                one_by_one.set(MeshId(id), joints.iter().copied(), weights)
            })
            .collect();
        for parts in [1, 2, 3, 7, 64] {
            let mut chunked = table(sources, joints, posed);
            let mut batch: Vec<_> = ids.iter().map(|&id| PoseSet::new(MeshId(id), id as usize % poses.len())).collect();
            let chunks: Vec<_> = chunked.chunks(&mut batch, parts).collect();
            assert!(chunks.len() <= parts);
            for chunk in chunks {
                chunk.set(|&i| (&poses[i].0[..], &poses[i].1[..]));
            }
            chunked.finish(&batch);
            for (&id, expected) in ids.iter().zip(&serial) {
                let set = batch.iter().find(|s| s.mesh.0 == id).expect("in the batch");
                assert_eq!(set.was_set(), expected.is_some(), "{parts} parts, mesh {id}");
                assert_eq!(set.bounds(), expected.flatten(), "{parts} parts, mesh {id}");
            }
            let mut reference = table(sources, joints, posed);
            for &id in &ids {
                let (joints, weights) = &poses[id as usize % poses.len()];
                reference.set(MeshId(id), joints.iter().copied(), weights);
            }
            assert_eq!(chunked.take_jobs(), reference.take_jobs(), "{parts} parts");
            assert_eq!(chunked.jobs().len(), reference.jobs().len(), "{parts} parts");
            assert_eq!(input(&chunked).len(), input(&reference).len(), "{parts} parts");
            let sorted = |t: &PoseTable| {
                let mut jobs = t.jobs().to_vec();
                jobs.sort_unstable_by_key(|m| m.0);
                jobs
            };
            assert_eq!(sorted(&chunked), sorted(&reference), "{parts} parts: the same poses skinned");
        }
    }
}
