//! Compiles every GLSL stage in `shaders/` to SPIR-V with the `glslc` program (Debian package
//! `glslc`). Debian's `libshaderc` does not link from Rust, so we call the program instead.
//! A shader error fails the build with glslc's own message, which names the file and line.
//! The stages compile in parallel, as many at once as cargo runs jobs.
//!
//! A stage whose first line is `// variants: NAME [NAME…]` is also compiled once per NAME with
//! `-DNAME`, into `<file>.<NAME>.spv` (e.g. the forward shader with and without ray-query
//! decals, since SPIR-V that uses ray queries cannot even be loaded on devices without them). A
//! NAME joining defines with `+` (`A+B`) is compiled with each of them.
//!
//! First it writes `$OUT_DIR/layout.glsl` from `src/layout.rs` (the Rust/GLSL records and
//! constants, compiled here as a module so its layout assertions run before the crate does) and
//! checks the header against glslang's own layout; shaders include it with `-I $OUT_DIR`.

// The layout! macro recurses once per record field; GpuLighting has more than 128 tokens' worth.
#![recursion_limit = "256"]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

#[allow(dead_code)]
#[path = "src/layout.rs"]
mod layout;

const STAGES: &[&str] = &["vert", "frag", "comp", "rgen", "rint", "rahit", "rchit", "rmiss"];

fn main() {
    // Read at run time (cargo sets it for build scripts), not baked in when the script is
    // compiled: a build script reused from another checkout must still read this one.
    let manifest_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let shader_dir = manifest_dir.join("../shaders");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed={}", shader_dir.display());
    println!("cargo:rerun-if-changed={}", shader_dir.join("include").display());
    println!("cargo:rerun-if-env-changed=GLSLC");

    println!("cargo:rerun-if-changed=src/layout.rs");

    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    write_if_changed(&out_dir.join("layout.glsl"), &layout::glsl());
    check_layout(&glslc, &out_dir);
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

    // As many glslc processes at once as cargo runs jobs (`NUM_JOBS`): after a shader edit the
    // crate's compile waits for this script. (A fresh build was no quicker for it: there other
    // crates keep the cores busy meanwhile, docs/TESTING.md.)
    let parallel = std::env::var("NUM_JOBS").ok().and_then(|n| n.parse::<usize>().ok()).unwrap_or(1).max(1);
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..parallel {
            scope.spawn(|| {
                while let Some((src, define, out)) = jobs.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let mut command = Command::new(&glslc);
                    command.arg("--target-env=vulkan1.3").arg("-O").arg("-I").arg(shader_dir.join("include")).arg("-I").arg(&out_dir);
                    for define in define.iter().flat_map(|d| d.split('+')) {
                        command.arg(format!("-D{define}"));
                    }
                    match command.arg(src).arg("-o").arg(out).output() {
                        Ok(o) if o.status.success() => {}
                        Ok(o) => failures.lock().unwrap().push(format!(
                            "{}{}{}",
                            define.as_ref().map(|d| format!("(variant {d}) ")).unwrap_or_default(),
                            String::from_utf8_lossy(&o.stdout),
                            String::from_utf8_lossy(&o.stderr)
                        )),
                        Err(e) => no_glslc(&glslc, e),
                    }
                }
            });
        }
    });
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    if !failures.is_empty() {
        panic!("shader compilation failed:\n{}", failures.join("\n"));
    }
}

fn no_glslc(glslc: &str, e: std::io::Error) -> ! {
    panic!(
        "could not run `{glslc}` ({e}); install it (Debian: `apt-get install glslc`, \
         or run scripts/setup.sh) or point the GLSLC variable at it"
    )
}

/// Writes `text` unless the file already holds it (so an unchanged layout touches nothing).
fn write_if_changed(path: &Path, text: &str) {
    if std::fs::read_to_string(path).ok().as_deref() != Some(text) {
        std::fs::write(path, text).unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
    }
}

/// Compiles a probe shader that puts every struct of `layout.glsl` in a block of its layout rule
/// (the push-constant block is already one), and compares the member offsets and array strides
/// glslang decorates the SPIR-V with against `layout::ITEMS` (which the Rust structs are
/// asserted against at compile time).
fn check_layout(glslc: &str, out_dir: &Path) {
    let structs: Vec<&layout::Struct> =
        layout::ITEMS.iter().filter_map(|item| if let layout::Item::Struct(s) = item { Some(*s) } else { None }).collect();
    let mut probe = String::from("#version 460\n#extension GL_EXT_scalar_block_layout : require\n#include \"layout.glsl\"\n");
    for (binding, s) in structs.iter().enumerate() {
        let rule = match s.rule {
            layout::Rule::Std430 => "std430",
            layout::Rule::Scalar => "scalar",
            layout::Rule::PushConstant => continue,
        };
        probe +=
            &format!("layout({rule}, binding = {binding}) readonly buffer Probe{binding} {{ {} records[]; }} probe{binding};\n", s.name);
    }
    probe += "layout(local_size_x = 1) in;\nvoid main() {}\n";
    let (src, asm) = (out_dir.join("layout_probe.comp"), out_dir.join("layout_probe.spvasm"));
    write_if_changed(&src, &probe);
    let output = Command::new(glslc)
        .args(["--target-env=vulkan1.3", "-S", "-I"])
        .arg(out_dir)
        .arg(&src)
        .arg("-o")
        .arg(&asm)
        .output()
        .unwrap_or_else(|e| no_glslc(glslc, e));
    if !output.status.success() {
        panic!("layout.glsl does not compile:\n{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    }
    let asm = std::fs::read_to_string(&asm).expect("glslc wrote the probe's SPIR-V assembly");

    // `OpMemberDecorate %GpuCamera 4 Offset 256`, `OpDecorate %_runtimearr_GpuCamera ArrayStride 304`.
    let mut offsets: BTreeMap<&str, BTreeMap<usize, usize>> = BTreeMap::new();
    let mut strides: BTreeMap<&str, usize> = BTreeMap::new();
    for words in asm.lines().map(|l| l.split_whitespace().collect::<Vec<_>>()) {
        match words[..] {
            ["OpMemberDecorate", ty, member, "Offset", offset] => {
                offsets.entry(ty.trim_start_matches('%')).or_default().insert(member.parse().unwrap(), offset.parse().unwrap());
            }
            ["OpDecorate", ty, "ArrayStride", stride] => {
                if let Some(name) = ty.strip_prefix("%_runtimearr_") {
                    strides.insert(name, stride.parse().unwrap());
                }
            }
            _ => {}
        }
    }
    let mut errors = Vec::new();
    for s in &structs {
        let glslang: Vec<usize> = offsets.get(s.name).map(|m| m.values().copied().collect()).unwrap_or_default();
        let ours: Vec<usize> = s.fields.iter().map(|f| f.offset).collect();
        if glslang != ours {
            errors.push(format!("{}: glslang places the fields at {glslang:?}, layout.rs at {ours:?}", s.name));
        }
        if s.rule != layout::Rule::PushConstant && strides.get(s.name) != Some(&s.size) {
            errors.push(format!("{}: glslang's array stride is {:?}, layout.rs's size {}", s.name, strides.get(s.name), s.size));
        }
    }
    if !errors.is_empty() {
        panic!("src/layout.rs computes layouts that glslang disagrees with (fix the rules there):\n{}", errors.join("\n"));
    }
}
