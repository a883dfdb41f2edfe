//! Compiles every GLSL stage in `shaders/` to SPIR-V with the `glslc` program (Debian package
//! `glslc`). Debian's `libshaderc` does not link from Rust, so we call the program instead.
//! A shader error fails the build with glslc's own message, which names the file and line.
//!
//! A stage whose first line is `// variants: NAME [NAME…]` is also compiled once per NAME with
//! `-DNAME`, into `<file>.<NAME>.spv` (e.g. the forward shader with and without ray-query
//! decals, since SPIR-V that uses ray queries cannot even be loaded on devices without them).

use std::path::{Path, PathBuf};
use std::process::Command;

const STAGES: &[&str] = &["vert", "frag", "comp", "rgen", "rint", "rahit", "rchit", "rmiss"];

fn main() {
    let shader_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed={}", shader_dir.display());
    println!("cargo:rerun-if-changed={}", shader_dir.join("include").display());
    println!("cargo:rerun-if-env-changed=GLSLC");

    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    let mut sources: Vec<PathBuf> = std::fs::read_dir(&shader_dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", shader_dir.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| STAGES.contains(&e)))
        .collect();
    sources.sort();
    for entry in std::fs::read_dir(shader_dir.join("include")).into_iter().flatten().flatten() {
        println!("cargo:rerun-if-changed={}", entry.path().display());
    }

    let mut jobs = Vec::new();
    for src in &sources {
        println!("cargo:rerun-if-changed={}", src.display());
        let name = src.file_name().unwrap().to_string_lossy().into_owned();
        jobs.push((src.clone(), None, out_dir.join(format!("{name}.spv"))));
        let text = std::fs::read_to_string(src).unwrap_or_default();
        if let Some(list) = text.lines().next().and_then(|l| l.strip_prefix("// variants:")) {
            for variant in list.split_whitespace() {
                jobs.push((src.clone(), Some(variant.to_string()), out_dir.join(format!("{name}.{variant}.spv"))));
            }
        }
    }

    let mut failures = Vec::new();
    for (src, define, out) in &jobs {
        let mut command = Command::new(&glslc);
        command.arg("--target-env=vulkan1.3").arg("-O").arg("-I").arg(shader_dir.join("include"));
        if let Some(define) = define {
            command.arg(format!("-D{define}"));
        }
        let result = command.arg(src).arg("-o").arg(out).output();
        match result {
            Ok(o) if o.status.success() => {}
            Ok(o) => failures.push(format!(
                "{}{}{}",
                define.as_ref().map(|d| format!("(variant {d}) ")).unwrap_or_default(),
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            )),
            Err(e) => panic!(
                "could not run `{glslc}` ({e}); install it (Debian: `apt-get install glslc`, \
                 or run scripts/setup.sh) or point the GLSLC variable at it"
            ),
        }
    }
    if !failures.is_empty() {
        panic!("shader compilation failed:\n{}", failures.join("\n"));
    }
}
