//! The crate's layering, checked on its sources (the rules of the crate docs' "Layers"): the
//! lower layers name no technique, only `renderer.rs` and `lib.rs` import `crate::renderer`,
//! and a technique imports another only for the typed outputs listed there.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers below the techniques.
const LOWER: [&str; 7] = ["gpu", "graph", "scene", "layout", "settings", "stats", "error"];
/// Not techniques: the frame functions, which own every technique, and the renderer.
const ABOVE: [&str; 3] = ["pipelines", "renderer", "lib"];
/// The technique imports the crate docs list: each for a frame function's typed output.
const ALLOWED: [(&str, &str); 10] = [
    ("shadows", "culling"),
    ("transparency", "culling"),
    ("reflections", "decals"),
    ("transparency", "decals"),
    ("shadows", "lights"),
    ("reflections", "lights"),
    ("transparency", "lights"),
    ("particles", "lights"),
    ("lights", "accel"),
    ("lights", "environment"),
];
/// The rest of the fourth entry: the frames the lighting record is built from.
const ALLOWED_LIGHTS: [&str; 2] = ["occlusion", "reflections"];

/// Every `crate::<module>` path named in code (comments left out) of each top-level module.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("render/src is readable") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let relative = path.strip_prefix(&root).expect("under src");
            let first = relative.components().next().expect("a component").as_os_str().to_string_lossy();
            let module = first.trim_end_matches(".rs").to_string();
            let text = std::fs::read_to_string(&path).expect("a source file is readable");
            let named = out.entry(module).or_default();
            for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
                let code = line.split("//").next().unwrap_or("");
                for (at, _) in code.match_indices("crate::") {
                    let name: String = code[at + 7..].chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                    if !name.is_empty() {
                        named.insert(name);
                    }
                }
            }
        }
    }
    out
}

#[test]
fn the_render_crates_layers_point_one_way() {
    let imports = imports();
    assert!(imports.len() > 20, "the sources were found: {:?}", imports.keys());
    let technique = |m: &str| !LOWER.contains(&m) && !ABOVE.contains(&m);
    let mut wrong = Vec::new();
    for (module, named) in &imports {
        for name in named.iter().filter(|n| *n != module) {
            let fine = if name == "renderer" {
                ABOVE.contains(&module.as_str())
            } else if LOWER.contains(&module.as_str()) {
                !technique(name)
            } else if technique(module) && technique(name) {
                ALLOWED.contains(&(module.as_str(), name.as_str())) || (module == "lights" && ALLOWED_LIGHTS.contains(&name.as_str()))
            } else {
                true
            };
            if !fine {
                wrong.push(format!("{module} → {name}"));
            }
        }
    }
    assert!(wrong.is_empty(), "imports against the crate's layers (see lib.rs, \"Layers\"): {wrong:?}");
}
