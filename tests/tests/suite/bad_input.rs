//! Bad input while a scene is running: a malformed glTF, one that references a missing file and
//! one with an unsupported attribute layout each give an error that names the problem; one whose
//! skin and clip channel are broken loads all the rest; nothing panics, and the running scene
//! keeps rendering without validation errors.

use std::path::{Path, PathBuf};

use plugins::RenderMirror;
use sandbox::headless::{SceneSource, load_scene};
use tests::{assert_no_validation_errors, gpu_app};

/// A one-triangle glTF. With `u32_uvs`, TEXCOORD_0 is stored as unsigned 32-bit integers, a
/// layout glTF does not allow for texture coordinates.
fn triangle_gltf(dir: &Path, name: &str, u32_uvs: bool, write_bin: bool) -> PathBuf {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let uvs: [u32; 6] = [0, 0, 1, 0, 0, 1];
    let mut bytes: Vec<u8> = positions.iter().flat_map(|f| f.to_le_bytes()).collect();
    bytes.extend(uvs.iter().flat_map(|u| u.to_le_bytes()));
    let bin = format!("{name}.bin");
    let (uv_view, uv_accessor, uv_attribute) = if u32_uvs {
        (
            r#",{"buffer":0,"byteOffset":36,"byteLength":24}"#,
            r#",{"bufferView":1,"componentType":5125,"count":3,"type":"VEC2"}"#,
            r#","TEXCOORD_0":1"#,
        )
    } else {
        ("", "", "")
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},
  "buffers":[{{"uri":"{bin}","byteLength":60}}],
  "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}{uv_view}],
  "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}{uv_accessor}],
  "meshes":[{{"name":"Tri","primitives":[{{"attributes":{{"POSITION":0{uv_attribute}}}}}]}}],
  "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#
    );
    if write_bin {
        std::fs::write(dir.join(&bin), &bytes).unwrap();
    }
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, json).unwrap();
    path
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ecs-decals-bad-input-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn bad_gltf_files_are_clear_errors_and_tear_nothing_down() {
    let dir = temp_dir("gltf");
    let valid = triangle_gltf(&dir, "valid", false, true);
    let missing_bin = triangle_gltf(&dir, "missing", false, false);
    let int_uvs = triangle_gltf(&dir, "int_uvs", true, true);
    let malformed = dir.join("malformed.gltf");
    let text = std::fs::read_to_string(&valid).unwrap();
    std::fs::write(&malformed, &text[..text.len() / 2]).unwrap();

    let mut app = gpu_app(96, 64, Default::default());
    load_scene(&mut app.world, &SceneSource::Default, None).expect("the courtyard loads");
    app.update();
    let instances = app.world.resource::<RenderMirror>().0.instances.len();

    let cases: [(&Path, &[&str]); 4] = [
        (&malformed, &["malformed.gltf"]),
        (&missing_bin, &["missing.bin"]),
        (&int_uvs, &["Tri", "TEXCOORD_0"]),
        (Path::new("/nonexistent/scene.glb"), &["/nonexistent/scene.glb"]),
    ];
    for (path, must_name) in cases {
        let err = load_scene(&mut app.world, &SceneSource::Gltf(path.to_path_buf()), None).expect_err("a bad file is an error");
        let message = format!("{err:#}");
        for needle in must_name {
            assert!(message.contains(needle), "error for {} names {needle:?}: {message}", path.display());
        }
        app.update();
    }
    assert_eq!(app.world.resource::<RenderMirror>().0.instances.len(), instances, "the running scene is untouched");

    // The valid file still loads into the same running app afterwards.
    load_scene(&mut app.world, &SceneSource::Gltf(valid), None).expect("the valid triangle loads");
    app.update();
    assert_eq!(app.world.resource::<RenderMirror>().0.instances.len(), instances + 1);

    // A file whose skin and one clip channel are broken (issue 55) loads into the same app: its
    // two triangles draw (the skinned one in its rest pose), its clip plays, the picture is finite.
    let (mut broken, accessors) = tests::gltf_files::parts_model();
    broken.json["accessors"][accessors.inverse_binds]["count"] = 1.into();
    broken.json["animations"][0]["samplers"][1]["interpolation"] = "CUBICSPLINE".into();
    let broken_path = dir.join("broken_parts.glb");
    std::fs::write(&broken_path, broken.glb()).unwrap();
    load_scene(&mut app.world, &SceneSource::Gltf(broken_path), None).expect("a file with broken parts loads");
    app.update();
    app.update();
    assert_eq!(app.world.resource::<RenderMirror>().0.instances.len(), instances + 3);
    tests::renderer(&mut app).finish();
    let hdr = tests::renderer(&mut app).read_hdr().expect("read back the HDR target");
    assert!(hdr.iter().flatten().all(|c| c.is_finite()), "every pixel is finite");
    assert_no_validation_errors(&mut app);
    std::fs::remove_dir_all(&dir).ok();
}
