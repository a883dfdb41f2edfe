//! The `--stats` file: one JSON object per frame.
//!
//! Keys (stable; later features add keys, none change meaning): `frame`, `pipeline`,
//! `decal_method` (the method applied, which may differ from the one asked for: `none` when the
//! device can run no decal method in this pipeline), `tier`,
//! `device`, `size` `[w, h]`, `gpu_ms` (one key per pass plus `total`), `cpu_ms` (`extract`,
//! `record`), and `counters` (`bytes_uploaded`, `records_written`, `blas_builds`,
//! `blas_updates`, `tlas_builds`, `instances`, `lights`, `decals`).

use plugins::FrameStats;
use serde_json::{Map, Value, json};

/// One frame's statistics as a JSON object.
pub fn frame_json(stats: &FrameStats, tier: &str, device: &str) -> Value {
    let mut gpu = Map::new();
    for (name, ms) in stats.gpu.iter() {
        gpu.insert(name.to_string(), json!(round(ms)));
    }
    gpu.insert("total".into(), json!(round(stats.gpu.total_ms)));
    let c = &stats.counters;
    json!({
        "frame": stats.frame,
        "pipeline": stats.pipeline.name(),
        "decal_method": stats.decal_method.name(),
        "tier": tier,
        "device": device,
        "size": [stats.size.0, stats.size.1],
        "gpu_ms": gpu,
        "cpu_ms": { "extract": round(stats.cpu_extract_ms), "record": round(stats.cpu_record_ms) },
        "counters": {
            "bytes_uploaded": c.bytes_uploaded,
            "records_written": c.records_written,
            "blas_builds": c.blas_builds,
            "blas_updates": c.blas_updates,
            "tlas_builds": c.tlas_builds,
            "instances": c.instances,
            "lights": c.lights,
            "decals": c.decals,
        },
    })
}

fn round(ms: f32) -> f64 {
    (ms as f64 * 1e4).round() / 1e4
}
