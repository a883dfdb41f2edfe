//! glTF textures compressed at import and in KTX2 containers.
//!
//! - PNG textures compressed by role (`engine::image::compress`) render as their RGBA8
//!   originals do, within the errors stated at each assertion, on a floor that recedes so that
//!   its far half samples the small mips; the import cache is hit on a second load and missed
//!   when the image or the settings change.
//! - Basis Universal files (ETC1S and UASTC, `assets/tests/basis`) transcode and render as the
//!   PNG they were encoded from does, within stated errors.
//! - KTX2 containers (`KHR_texture_basisu`): block-compressed levels are used as they are; a
//!   container the loader cannot read (here a universal format over bytes that are not Basis
//!   Universal) falls back to the texture's PNG source, or without one to the placeholder, and
//!   the rest of the file loads.

use engine::gltf::{CacheLocation, GltfScene, LoadOptions, TextureImport, glb_container, load_slice};
use engine::image::{Image, TexelFormat, TextureRole};
use engine::prelude::*;
use plugins::RenderSettings;
use tests::{assert_no_validation_errors, error_stats, gpu_app, renderer};

/// An 8×8 BC1 texture of one colour (four identical blocks), as a KTX2 file; `universal` marks
/// its format undefined, as Basis Universal containers are.
fn bc1_ktx2(universal: bool) -> Vec<u8> {
    let block = [0xFF, 0x07, 0xFF, 0x07, 0, 0, 0, 0];
    let mut file = tests::ktx2_file(ktx2::Format::BC1_RGBA_SRGB_BLOCK, 8, 8, 1, &block.repeat(4));
    if universal {
        file[12..16].fill(0); // vkFormat: VK_FORMAT_UNDEFINED
    }
    file
}

/// A 2×2 white PNG.
fn png() -> Vec<u8> {
    let mut bytes = Vec::new();
    let image = image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 255, 255, 255]));
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    bytes
}

/// A textured triangle whose texture's `KHR_texture_basisu` image is `ktx2`, with `fallback`
/// as its own PNG source when given.
fn textured_triangle(ktx2: &[u8], fallback: Option<&[u8]>) -> GltfScene {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let uvs: [f32; 6] = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
    let mut bin: Vec<u8> = positions.iter().chain(&uvs).flat_map(|f| f.to_le_bytes()).collect();
    let ktx2_at = bin.len();
    bin.extend_from_slice(ktx2);
    bin.resize(bin.len().next_multiple_of(4), 0);
    let png_at = bin.len();
    let png = fallback.unwrap_or_default();
    bin.extend_from_slice(png);
    bin.resize(bin.len().next_multiple_of(4), 0);
    let (source, png_image, png_view) = match fallback {
        Some(_) => (
            r#""source":1,"#,
            r#",{"bufferView":3,"mimeType":"image/png"}"#,
            format!(r#",{{"buffer":0,"byteOffset":{png_at},"byteLength":{}}}"#, png.len()),
        ),
        None => ("", "", String::new()),
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_texture_basisu"],"extensionsRequired":["KHR_texture_basisu"],
  "buffers":[{{"byteLength":{}}}],
  "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":24}},
                 {{"buffer":0,"byteOffset":{ktx2_at},"byteLength":{}}}{png_view}],
  "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
               {{"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"}}],
  "images":[{{"bufferView":2,"mimeType":"image/ktx2"}}{png_image}],
  "textures":[{{{source}"extensions":{{"KHR_texture_basisu":{{"source":0}}}}}}],
  "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
  "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"material":0}}]}}],
  "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len(),
        ktx2.len()
    );
    load_slice(&glb_container(json.as_bytes(), &bin), None).expect("the textured triangle loads")
}

fn base_colour(scene: &GltfScene) -> &engine::image::Image {
    &scene.images[scene.materials[0].base_color_texture.expect("a base colour texture")]
}

#[test]
fn ktx2_textures_load_as_their_blocks_or_fall_back() {
    // BC1 levels, used as they are (no fallback needed: the texture names no other image).
    let scene = textured_triangle(&bc1_ktx2(false), None);
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width, image.height, image.mip_count()), (TexelFormat::Bc1, 8, 8, 1), "{image:?}");
    assert_eq!(image.mips[0].len(), 32, "four 8-byte blocks");

    // A universal format over bytes the Basis Universal transcoder cannot read: the PNG source
    // is used, compressed as every PNG is by default.
    let scene = textured_triangle(&bc1_ktx2(true), Some(&png()));
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width), (TexelFormat::Bc7, 2), "the fallback PNG: {image:?}");

    // A Basis Universal image (UASTC, Zstandard-supercompressed) is transcoded to BC7.
    let scene = textured_triangle(&basis_asset("colour_uastc.ktx2"), None);
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width, image.mip_count()), (TexelFormat::Bc7, 32, 6), "the transcoded UASTC: {image:?}");
    assert_eq!(scene.texture_import.ktx2, 1);

    // Without a PNG source the texture gets the placeholder, and the rest of the file loads.
    let scene = textured_triangle(&bc1_ktx2(true), None);
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width), (TexelFormat::Rgba8, 16), "the magenta checker: {image:?}");
    assert_eq!(&image.mips[0][..4], &[255, 0, 255, 255]);
    assert_eq!(scene.triangle_count(), 1);
}

/// A 64×64 texture with smooth gradients, hard edges and texel noise in every channel, the
/// content block compression finds hardest: for `Normal`, the normals of a field of bumps.
fn test_texture(role: TextureRole) -> Vec<u8> {
    let n = 64usize;
    let noise = |x: usize, y: usize| ((x * 7919 + y * 104_729) ^ (x * y * 31)) % 23;
    (0..n * n)
        .flat_map(|i| {
            let (x, y) = (i % n, i / n);
            let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
            let checker = if (x / 8 + y / 8) % 2 == 0 { 60 } else { 0 };
            match role {
                TextureRole::Normal => {
                    let (a, b) = (u * std::f32::consts::TAU * 4.0, v * std::f32::consts::TAU * 4.0);
                    let normal = Vec3::new(-0.6 * a.cos() * b.sin(), -0.6 * a.sin() * b.cos(), 1.0).normalize();
                    let encode = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
                    [encode(normal.x), encode(normal.y), encode(normal.z), 255]
                }
                _ => [
                    (u * 150.0) as u8 + checker + noise(x, y) as u8,
                    (v * 150.0 + 40.0) as u8 + noise(y, x) as u8,
                    ((1.0 - u) * 120.0) as u8 + checker,
                    255,
                ],
            }
        })
        .collect()
}

/// A test texture of `assets/tests/basis` (see its `PROVENANCE.md`); a missing file fails.
fn basis_asset(name: &str) -> Vec<u8> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/tests/basis").join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The floor's pixels shaded with `image` in the slot `role` fills.
fn shade_floor(app: &mut App, floor: Entity, mesh: Handle<Mesh>, image: Image, role: TextureRole) -> Vec<[f32; 4]> {
    let image = app.world.resource_mut::<Assets<Image>>().add(image);
    let base = Material::from_color(Vec4::ONE, 0.0, 0.6);
    let material = match role {
        TextureRole::Color => Material { base_color_texture: Some(image), ..base },
        TextureRole::Data => Material { metallic: 1.0, roughness: 1.0, metallic_roughness_texture: Some(image), ..base },
        TextureRole::Normal => Material { normal_texture: Some(image), ..base },
        TextureRole::Mask => Material { occlusion_texture: Some(image), ..base },
    };
    let material = app.world.resource_mut::<Assets<Material>>().add(material);
    app.world.entity_mut(floor).insert(MeshInstance { mesh, material });
    app.update();
    app.update();
    renderer(app).read_hdr().expect("readback")
}

/// Each role's texture compressed at import, and Basis Universal textures (ETC1S and UASTC)
/// transcoded, shade the floor as their RGBA8 originals do. The floor runs from the camera's
/// feet to the horizon, so that its far half samples the small mips.
#[test]
fn compressed_and_basis_textures_render_as_their_originals() {
    let size = (96u32, 64u32);
    let settings = RenderSettings { ambient: Vec3::splat(0.4), ..Default::default() };
    let mut app = gpu_app(size.0, size.1, settings);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(16.0, 16.0, 1, 0.25));
    let floor = app.world.spawn(Transform::IDENTITY).id();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.5, 4.0).looking_at(Vec3::new(0.0, 0.0, -2.0), Vec3::Y)));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::IDENTITY.looking_at(Vec3::new(0.3, -1.0, -0.6), Vec3::Y),
    ));
    // Mean and 99th-percentile error over every pixel and channel, relative to the original's
    // mean brightness.
    let compare = |app: &mut App, what: &str, original: Image, compressed: Image, role: TextureRole, bounds: (f32, f32)| {
        let (original, compressed) = (shade_floor(app, floor, mesh, original, role), shade_floor(app, floor, mesh, compressed, role));
        let brightness = original.iter().flat_map(|p| &p[..3]).sum::<f32>() / (original.len() * 3) as f32;
        let (mean, p99) = error_stats(&original, &compressed, |_| true);
        let (mean, p99) = (mean / brightness, p99 / brightness);
        eprintln!("{what}: mean error {:.2} %, 99th percentile {:.2} % of the mean brightness {brightness:.3}", mean * 100.0, p99 * 100.0);
        assert!(mean <= bounds.0 && p99 <= bounds.1, "{what}: mean error {mean:.4}, 99th percentile {p99:.4}, over {bounds:?}");
    };
    // Compressed at import. Measured on lavapipe: colour 0.99 % and 11.8 % (the texture's
    // per-texel noise is what BC7's 4×4 blocks smooth), metallic-roughness 0.32 % and 3.2 %,
    // occlusion 0.13 % and 1.1 %, normals 0.22 % and 1.9 %.
    for (role, bounds) in [
        (TextureRole::Color, (0.015, 0.15)),
        (TextureRole::Data, (0.005, 0.05)),
        (TextureRole::Mask, (0.002, 0.02)),
        (TextureRole::Normal, (0.004, 0.03)),
    ] {
        let texels = test_texture(role);
        let original = Image::from_rgba8_for(64, 64, texels.clone(), role).unwrap();
        let compressed = Image::compress(64, 64, texels, role).unwrap();
        assert_eq!((compressed.format, compressed.mip_count()), (role.compressed_format(), 7));
        compare(&mut app, &format!("{role:?} compressed"), original, compressed, role, bounds);
    }

    // Basis Universal, transcoded to BC7 (colour) and BC5 (two-channel normal maps), against
    // the PNG the files were encoded from. ETC1S is the smaller, lossier payload by design (its
    // level 0 decodes 4.2 sRGB codes from the source on average, UASTC's 0.34), and the files'
    // mips are the encoder's own filter, not ours. Measured on lavapipe: ETC1S colour 5.9 % and
    // 53 % (the checker's edges), UASTC colour 1.5 % and 15 %; normals 0.87 % and 11 % (ETC1S),
    // 0.56 % and 5.1 % (UASTC).
    for (file, source, role, format, bounds) in [
        ("colour_etc1s.ktx2", "colour.png", TextureRole::Color, TexelFormat::Bc7, (0.08, 0.65)),
        ("colour_uastc.ktx2", "colour.png", TextureRole::Color, TexelFormat::Bc7, (0.025, 0.22)),
        ("normal_etc1s.ktx2", "normal.png", TextureRole::Normal, TexelFormat::Bc5, (0.015, 0.16)),
        ("normal_uastc.ktx2", "normal.png", TextureRole::Normal, TexelFormat::Bc5, (0.01, 0.08)),
    ] {
        let transcoded = Image::from_ktx2_for(&basis_asset(file), role, file).expect("the Basis texture transcodes");
        assert_eq!((transcoded.format, transcoded.width, transcoded.mip_count()), (format, 32, 6), "{file}");
        let (w, h, texels) = Image::decode_rgba8(&basis_asset(source)).expect("the source PNG");
        compare(&mut app, file, Image::from_rgba8_for(w, h, texels, role).unwrap(), transcoded, role, bounds);
    }

    // A texture budget: a 256² RGBA8 texture (349,524 bytes with its mips) arriving with 100 KiB
    // of room left loses its finest levels until it fits (the 256² level goes: the 87,380 bytes
    // of 128² and down stay), and says so once.
    let warnings = tests::WarningLog::capture(&mut app);
    let resident = app.world.resource::<plugins::RenderStats>().last.texture_budget.resident;
    renderer(&mut app).set_texture_budget(resident + 100 * 1024);
    let big = Image::from_rgba8_for(256, 256, vec![200; 256 * 256 * 4], TextureRole::Color).unwrap();
    shade_floor(&mut app, floor, mesh, big, TextureRole::Color);
    let budget = app.world.resource::<plugins::RenderStats>().last.texture_budget;
    assert_eq!((budget.levels_dropped, budget.bytes_dropped), (1, 4 * 256 * 256), "{budget:?}");
    assert!(budget.resident <= budget.budget, "{budget:?}");
    let over = warnings.warnings().into_iter().filter(|w| w.message.contains("texture budget")).count();
    assert_eq!(over, 1, "one warning: {:?}", warnings.warnings());
    assert_no_validation_errors(&mut app);
}

/// A glTF's PNG texture is compressed into the cache on the first load, read from it on the
/// second (counted), and compressed again when the image or the role it is used in changes.
#[test]
fn the_import_cache_is_hit_and_missed_as_the_sources_change() {
    let dir = std::env::temp_dir().join(format!("ecs-decals-import-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // The progress callback hears of each image: how far, and how it was imported.
    let events = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let heard = events.clone();
    let progress: engine::gltf::TextureProgress =
        std::sync::Arc::new(move |e: &engine::gltf::TextureEvent<'_>| heard.lock().unwrap().push((e.done, e.total, e.import)));
    let options =
        LoadOptions { textures: TextureImport::Compressed(CacheLocation::At(dir.clone())), progress: Some(progress), ..Default::default() };
    let png = |seed: u8| {
        let mut bytes = Vec::new();
        let image = image::RgbaImage::from_fn(8, 8, |x, y| image::Rgba([(x as u8 * 30) ^ seed, y as u8 * 30, seed, 255]));
        image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
        bytes
    };
    // One PNG, as base colour or as normal map.
    let model = |png: &[u8], slot: &str| {
        let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let mut bin: Vec<u8> = positions.iter().flat_map(|f| f.to_le_bytes()).collect();
        bin.extend_from_slice(png);
        bin.resize(bin.len().next_multiple_of(4), 0);
        let material = match slot {
            "normal" => r#"{"normalTexture":{"index":0}}"#,
            _ => r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}"#,
        };
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{}}}],
  "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":{}}}],
  "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
  "images":[{{"bufferView":1,"mimeType":"image/png"}}],"textures":[{{"source":0}}],"materials":[{material}],
  "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],"nodes":[{{"mesh":0}}]}}"#,
            bin.len(),
            png.len()
        );
        engine::gltf::load_slice_with(&glb_container(json.as_bytes(), &bin), None, &options).expect("the model loads").texture_import
    };
    let first = model(&png(1), "colour");
    assert_eq!((first.compressed, first.cache_hits), (1, 0), "the first load compresses: {first:?}");
    let second = model(&png(1), "colour");
    assert_eq!((second.compressed, second.cache_hits), (0, 1), "the second load reads the cache: {second:?}");
    let edited = model(&png(2), "colour");
    assert_eq!((edited.compressed, edited.cache_hits), (1, 0), "an edited image is compressed again: {edited:?}");
    let normal = model(&png(1), "normal");
    assert_eq!((normal.compressed, normal.cache_hits), (1, 0), "another role is another setting: {normal:?}");
    use engine::gltf::TextureSource::{CacheHit, Compressed};
    let expected = [(1, 1, Compressed), (1, 1, CacheHit), (1, 1, Compressed), (1, 1, Compressed)];
    assert_eq!(*events.lock().unwrap(), expected, "one event an image, in order");
    let _ = std::fs::remove_dir_all(&dir);
}
