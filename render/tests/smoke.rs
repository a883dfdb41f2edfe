//! A lit quad through the whole forward pipeline, built from plain data (no ECS): the device is
//! described truthfully, the frame has the requested size, the quad is lit where the camera looks
//! at it, the sky around it is the clear colour, a frame in which nothing changed uploads
//! nothing, and the memory report accounts for every byte the allocator holds.

#![forbid(unsafe_code)]

use glam::{Mat4, Vec2, Vec3};
use render::scene::{DrawItem, GpuCamera, GpuInstance, GpuLight, GpuMaterial, MeshData, SceneMirror, TextureData};
use render::{FrameSettings, Renderer, RendererSettings, Tier};

fn quad() -> MeshData {
    let v = |x: f32, z: f32| render::scene::Vertex {
        position: [x, 0.0, z],
        normal: [0.0, 1.0, 0.0],
        uv: [x, z],
        tangent: [1.0, 0.0, 0.0, 1.0],
    };
    MeshData {
        vertices: vec![v(-1.0, -1.0), v(-1.0, 1.0), v(1.0, 1.0), v(1.0, -1.0)],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Default::default()
    }
}

/// A 4 m quad lit by a point light, seen from above at an angle by a `w`×`h` camera; returns the
/// mirror and the quad's material.
fn lit_quad(w: u32, h: u32) -> (SceneMirror, u32) {
    let mut m = SceneMirror::new();
    let mesh = m.add_mesh(quad());
    let mat = m.materials.insert(GpuMaterial::default());
    m.set_instance(
        None,
        GpuInstance::new(Mat4::from_scale(Vec3::splat(4.0)), mat, 1),
        DrawItem { mesh, alpha_mask: false, double_sided: false, transparent: false },
    );
    m.lights.insert(GpuLight::point(Vec3::new(0.0, 1.0, 0.0), Vec3::splat(5.0), 10.0));
    let view = Mat4::look_at_rh(Vec3::new(0.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, w as f32 / h as f32, 0.1);
    m.set_camera(GpuCamera {
        view,
        proj,
        view_proj: proj * view,
        inv_view_proj: (proj * view).inverse(),
        position: Vec3::new(0.0, 2.0, 3.0),
        exposure: 1.0,
        viewport_size: Vec2::new(w as f32, h as f32),
        inv_viewport_size: Vec2::new(1.0 / w as f32, 1.0 / h as f32),
        ..Default::default()
    });
    (m, mat)
}

#[test]
fn lit_quad_renders_and_quiet_frames_upload_nothing() {
    let (w, h) = (64, 48);
    let mut r = Renderer::new(&RendererSettings::default(), w, h).expect("renderer");
    assert!(r.validation_enabled(), "tests run with the validation layer");
    assert!(!r.device_name().trim().is_empty(), "the device has a name");
    let tier = r.tier();
    assert!(
        [Tier::NoRayTracing, Tier::RayTracingPipeline, Tier::RayQuery].contains(&tier) && Tier::from_name(tier.name()) == Some(tier),
        "the tier in use is a known tier: {tier:?}"
    );
    assert_eq!(tier, r.capabilities().best_tier(), "without a cap the device's best tier is used");
    assert_eq!(r.size(), (w, h), "the renderer has the requested size");

    let (mut m, mat) = lit_quad(w, h);
    let settings = FrameSettings::default();
    let first = r.render(&mut m, &settings).expect("frame");
    assert_eq!(first.frame, 0, "frames are numbered from 0");
    assert!(first.counters.bytes_uploaded > 0, "the first frame uploads the scene");
    assert_eq!((first.counters.instances, first.counters.lights), (1, 1), "one quad and one light: {:?}", first.counters);
    m.begin_frame();
    let quiet = r.render(&mut m, &settings).expect("frame");
    assert_eq!(quiet.frame, 1);
    assert_eq!(quiet.counters.bytes_uploaded, 0, "a frame with no change uploads nothing");
    assert_eq!(quiet.counters.records_written, 0, "a frame with no change writes no record");

    // Where the bytes go: every allocation counted by kind. The allocator's total also holds the
    // padding it leaves between allocations to align them, a few bytes each.
    let (memory, allocator) = (quiet.counters.memory, r.gpu_memory_in_use());
    let padding = allocator.checked_sub(memory.total()).unwrap_or_else(|| panic!("more counted than allocated: {memory:?}, {allocator}"));
    assert!(padding * 200 <= allocator, "the report's total {} is the allocator's {allocator} but for padding", memory.total());
    use render::gpu::memory::MemoryKind;
    for kind in
        [MemoryKind::Textures, MemoryKind::MeshPool, MemoryKind::Targets, MemoryKind::Tables, MemoryKind::Lists, MemoryKind::HostVisible]
    {
        assert!(memory.of(kind) > 0, "{} hold memory: {memory:?}", kind.name());
    }
    let by_format: u64 = memory.texture_formats().map(|(_, bytes)| bytes).sum();
    assert_eq!(by_format, memory.of(MemoryKind::Textures), "the textures' bytes by format add up: {memory:?}");
    assert!(memory.texture_formats().any(|(f, _)| f == ash::vk::Format::R8G8B8A8_UNORM), "the built-in textures are RGBA8: {memory:?}");

    let hdr = r.read_hdr().expect("readback");
    let depth = r.read_depth().expect("depth readback");
    assert_eq!(hdr.len(), (w * h) as usize, "the HDR frame is {w}x{h}");
    assert_eq!(depth.len(), (w * h) as usize, "the depth frame is {w}x{h}");
    assert!(hdr.iter().flatten().all(|v| v.is_finite()), "no NaN or infinity in the HDR target");
    // The camera looks at the quad's centre; the top rows look past its far edge (about 20 m
    // away at the top corners, the quad ends at 4 m) into the clear colour.
    let centre_index = (h / 2 * w + w / 2) as usize;
    let centre = hdr[centre_index];
    assert!(centre[..3].iter().all(|&c| c > 0.01), "centre pixel is lit: {centre:?}");
    assert!(depth[centre_index] > 0.0, "geometry covers the centre (reverse-Z depth {})", depth[centre_index]);
    let corner = hdr[0];
    let clear = settings.clear_color;
    assert!(corner[..3].iter().zip(&clear).all(|(c, k)| (c - k).abs() < 1e-3), "corner pixel {corner:?} is the clear colour {clear:?}");
    assert_eq!(depth[0], 0.0, "nothing covers the corner (reverse-Z far plane)");

    // A block-compressed texture is sampled as it is: a BC1 texture of solid cyan (8×8 with its
    // mips, the last ones smaller than a block) shades the quad as the same colour in RGBA8 does.
    assert!(r.capabilities().texture_compression_bc, "every device this renderer runs on samples BC textures");
    {
        let cyan_block = [0xFF, 0x07, 0xFF, 0x07, 0, 0, 0, 0]; // colour0 = colour1 = 0x07FF (R5 0, G6 63, B5 31)
        let bc1 = TextureData {
            width: 8,
            height: 8,
            format: ash::vk::Format::BC1_RGBA_SRGB_BLOCK,
            mips: vec![cyan_block.repeat(4), cyan_block.to_vec(), cyan_block.to_vec(), cyan_block.to_vec()],
        };
        let rgba = TextureData {
            width: 8,
            height: 8,
            format: ash::vk::Format::R8G8B8A8_SRGB,
            mips: [8usize, 4, 2, 1].iter().map(|n| [0, 255, 255, 255].repeat(n * n)).collect(),
        };
        // The centre pixel once the material samples `texture` where `bind` puts it.
        let mut shade_with = |texture: TextureData, bind: fn(GpuMaterial, u32) -> GpuMaterial| {
            let slot = m.add_texture(texture);
            m.materials.write(mat, bind(*m.materials.get(mat).expect("the material"), slot));
            for _ in 0..2 {
                m.begin_frame();
                r.render(&mut m, &settings).expect("frame");
            }
            r.read_hdr().expect("readback")[centre_index]
        };
        let base_colour = |m: GpuMaterial, slot: u32| GpuMaterial { base_color_tex: slot, ..m };
        let (compressed, plain) = (shade_with(bc1, base_colour), shade_with(rgba, base_colour));
        assert!(compressed[0] < 0.05 * compressed[1] && compressed[1] > 0.01, "the BC1 texture shades cyan: {compressed:?}");
        assert!(compressed.iter().zip(&plain).all(|(a, b)| (a - b).abs() < 1e-4), "BC1 {compressed:?} against RGBA8 {plain:?}");

        // A BC5 normal map holds X and Y only (blue samples as 0): Z is rebuilt, so a flat one
        // shades as the RGBA8 flat normal does, not as a normal pointing into the surface.
        let flat_xy = [128, 128, 0, 0, 0, 0, 0, 0, 128, 128, 0, 0, 0, 0, 0, 0];
        let bc5 = TextureData {
            width: 4,
            height: 4,
            format: ash::vk::Format::BC5_UNORM_BLOCK,
            mips: vec![flat_xy.to_vec(), flat_xy.to_vec(), flat_xy.to_vec()],
        };
        let rgba_flat = TextureData {
            width: 4,
            height: 4,
            format: ash::vk::Format::R8G8B8A8_UNORM,
            mips: [4usize, 2, 1].iter().map(|n| [128, 128, 255, 255].repeat(n * n)).collect(),
        };
        let normals = |m: GpuMaterial, slot: u32| GpuMaterial { normal_tex: slot, normal_scale: 1.0, ..m };
        let (two_channel, three_channel) = (shade_with(bc5, normals), shade_with(rgba_flat, normals));
        assert!(
            two_channel.iter().zip(&three_channel).all(|(a, b)| (a - b).abs() < 2e-3 * b.abs().max(1.0)),
            "BC5 normals {two_channel:?} against RGBA8 {three_channel:?}"
        );
    }
    let errors = r.take_validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:#?}");
    eprintln!("centre {centre:?} corner {corner:?} device {} tier {}", r.device_name(), tier.name());
}

/// A device that cannot sample BC textures (as `without_texture_compression` pretends) gets
/// them decoded to RGBA8: the BC1 cyan texture shades the quad cyan, and no BC image exists.
#[test]
fn without_bc_textures_are_decoded_to_rgba8_and_float_scene_textures_are_refused() {
    let (w, h) = (32, 24);
    let device = render::DeviceSettings { without_texture_compression: true, ..Default::default() };
    let mut r = Renderer::new(&RendererSettings { device, ..Default::default() }, w, h).expect("renderer");
    assert!(!r.capabilities().texture_compression_bc);
    let (mut m, mat) = lit_quad(w, h);
    let cyan_block = [0xFF, 0x07, 0xFF, 0x07, 0, 0, 0, 0];
    let bc1 = TextureData {
        width: 8,
        height: 8,
        format: ash::vk::Format::BC1_RGBA_SRGB_BLOCK,
        mips: vec![cyan_block.repeat(4), cyan_block.to_vec(), cyan_block.to_vec(), cyan_block.to_vec()],
    };
    let slot = m.add_texture(bc1);
    m.materials.write(mat, GpuMaterial { base_color_tex: slot, ..*m.materials.get(mat).expect("the material") });
    let settings = FrameSettings::default();
    for _ in 0..2 {
        r.render(&mut m, &settings).expect("frame");
        m.begin_frame();
    }
    let centre = r.read_hdr().expect("readback")[(h / 2 * w + w / 2) as usize];
    assert!(centre[0] < 0.05 * centre[1] && centre[1] > 0.01, "the decoded BC1 texture shades cyan: {centre:?}");
    let memory = r.gpu_memory();
    let bc = memory.texture_formats().filter(|(f, _)| format!("{f:?}").starts_with("BC")).count();
    assert_eq!(bc, 0, "no BC image on a device without BC: {memory:?}");
    let errors = r.take_validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:#?}");
    // RGBA32F is for the renderer's own tables in built-in slots (the area lights' LTC table),
    // fetched texel by texel: a scene texture in it, which materials would filter, is refused.
    m.add_texture(TextureData { width: 1, height: 1, format: ash::vk::Format::R32G32B32A32_SFLOAT, mips: vec![vec![0; 16]] });
    let refused = r.render(&mut m, &settings).expect_err("an RGBA32F scene texture is refused");
    assert!(refused.to_string().contains("RGBA32F"), "{refused}");
}
