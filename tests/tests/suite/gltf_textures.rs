//! glTF textures in KTX2 containers (`KHR_texture_basisu`): block-compressed levels are used as
//! they are; a container this loader cannot use yet (Basis Universal) falls back to the
//! texture's PNG source, or without one to the placeholder, and the rest of the file loads.

use engine::gltf::{GltfScene, glb_container, load_slice};
use engine::image::TexelFormat;

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

    // A universal format (Basis Universal) is not transcoded yet: the PNG source is used.
    let scene = textured_triangle(&bc1_ktx2(true), Some(&png()));
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width), (TexelFormat::Rgba8, 2), "the fallback PNG: {image:?}");

    // Without a PNG source the texture gets the placeholder, and the rest of the file loads.
    let scene = textured_triangle(&bc1_ktx2(true), None);
    let image = base_colour(&scene);
    assert_eq!((image.format, image.width), (TexelFormat::Rgba8, 16), "the magenta checker: {image:?}");
    assert_eq!(&image.mips[0][..4], &[255, 0, 255, 255]);
    assert_eq!(scene.triangle_count(), 1);
}
