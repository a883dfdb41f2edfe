//! What `--compare`, `--compare-lights` and `--compare-light-methods` write beside their JSON
//! lines: `STATS.csv` (the median GPU time of every pass of every run) and `STATS.svg` (one
//! stacked bar a run, a segment a pass), where people would rather look than read.
//!
//! A run is a stretch of consecutive frames with one pipeline, decal method, light method,
//! shadow method and light settings (as `scripts/bench_summary.py` splits them); its first
//! frames are warm-up and skipped (10, or half the run when it is shorter than 20 frames).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use plotters::prelude::*;
use serde_json::Value;

/// One run's label and the median milliseconds of each pass (and `total`).
#[derive(Clone, Debug, PartialEq)]
pub struct RunMedians {
    /// `pipeline/decal_method lights=… light_count=… shadows=…` plus the light and transparency settings.
    pub label: String,
    /// Pass name to median GPU milliseconds, `total` included.
    pub passes: BTreeMap<String, f64>,
}

/// Splits `frames` (the `--stats` objects) into runs and takes each pass's median.
pub fn run_medians(frames: &[Value]) -> Vec<RunMedians> {
    let key = |f: &Value| {
        let lights = &f["lights"];
        format!(
            "{}/{} lights={} light_count={} shadows={} tile={} aabb={} depth_mask={} ray_culling={} normals={} transparency={} refraction={} coloured={}",
            f["pipeline"].as_str().unwrap_or("?"),
            f["decal_method"].as_str().unwrap_or("?"),
            f["light_method"].as_str().unwrap_or("?"),
            f["counters"]["lights"],
            f["shadows"].as_str().unwrap_or("?"),
            lights["tile_size"],
            lights["aabb"],
            lights["depth_mask"],
            lights["shadow_ray_culling"],
            lights["normals"].as_str().unwrap_or("?"),
            f["transparency"].as_str().unwrap_or("?"),
            f["refraction"],
            lights["coloured_shadows"],
        )
    };
    let mut runs: Vec<(String, Vec<&Value>)> = Vec::new();
    for f in frames {
        let k = key(f);
        match runs.last_mut() {
            Some((last, rows)) if *last == k => rows.push(f),
            _ => runs.push((k, vec![f])),
        }
    }
    runs.into_iter()
        .map(|(label, rows)| {
            let skip = if rows.len() >= 20 { 10 } else { rows.len() / 2 };
            let mut samples: BTreeMap<String, Vec<f64>> = BTreeMap::new();
            for row in &rows[skip..] {
                for (pass, ms) in row["gpu_ms"].as_object().into_iter().flatten() {
                    if let Some(ms) = ms.as_f64() {
                        samples.entry(pass.clone()).or_default().push(ms);
                    }
                }
            }
            let passes = samples.into_iter().map(|(pass, mut v)| (pass, median(&mut v))).collect();
            RunMedians { label, passes }
        })
        .collect()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) * 0.5
    }
}

/// Writes `stats`'s CSV and SVG siblings for `runs`; returns their paths.
pub fn write(stats: &Path, runs: &[RunMedians]) -> Result<(PathBuf, PathBuf)> {
    let csv = stats.with_extension("csv");
    let svg = stats.with_extension("svg");
    let mut text = String::from("run,pass,median_ms\n");
    for run in runs {
        for (pass, ms) in &run.passes {
            text.push_str(&format!("\"{}\",{pass},{ms:.4}\n", run.label.replace('"', "'")));
        }
    }
    std::fs::write(&csv, text).with_context(|| format!("writing {}", csv.display()))?;
    chart(&svg, runs).map_err(|e| anyhow!("drawing {}: {e}", svg.display()))?;
    Ok((csv, svg))
}

/// Horizontal stacked bars: a bar a run, a segment a pass (the passes in one colour each across
/// runs), with the total at the bar's end.
fn chart(path: &Path, runs: &[RunMedians]) -> Result<(), Box<dyn std::error::Error>> {
    let passes: Vec<&String> = {
        let mut all: Vec<&String> = runs.iter().flat_map(|r| r.passes.keys()).filter(|p| *p != "total").collect();
        all.sort();
        all.dedup();
        all
    };
    let total = |r: &RunMedians| r.passes.iter().filter(|(p, _)| *p != "total").map(|(_, ms)| ms).sum::<f64>();
    let max = runs.iter().map(total).fold(0.1, f64::max);
    let height = 120 + 28 * runs.len() as u32 + 16 * passes.len() as u32;
    let root = SVGBackend::new(path, (1200, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("GPU time per pass, median ms", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(380)
        .build_cartesian_2d(0.0..max * 1.6, (0..runs.len()).into_segmented())?;
    let labels = short_labels(runs);
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(runs.len())
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        })
        .x_desc("ms")
        .draw()?;
    for (k, pass) in passes.iter().enumerate() {
        let colour = Palette99::pick(k).filled();
        let bars = runs.iter().enumerate().filter_map(|(i, run)| {
            let ms = *run.passes.get(*pass)?;
            let before: f64 = run.passes.iter().filter(|(p, _)| *p != "total" && p < pass).map(|(_, ms)| ms).sum();
            Some(Rectangle::new([(before, SegmentValue::Exact(i)), (before + ms, SegmentValue::Exact(i + 1))], colour))
        });
        chart.draw_series(bars)?.label(pass.as_str()).legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour));
    }
    chart.draw_series(runs.iter().enumerate().map(|(i, run)| {
        Text::new(format!("{:.2}", total(run)), (total(run) + max * 0.01, SegmentValue::CenterOf(i)), ("sans-serif", 12))
    }))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// The runs' labels without the words every run shares (after the pipeline and decal method).
fn short_labels(runs: &[RunMedians]) -> Vec<String> {
    let words: Vec<Vec<&str>> = runs.iter().map(|r| r.label.split(' ').collect()).collect();
    let shared = |w: &&str| words.len() > 1 && words.iter().all(|ws| ws.contains(w));
    words
        .iter()
        .map(|ws| ws.iter().enumerate().filter(|(i, w)| *i == 0 || !shared(w)).map(|(_, w)| *w).collect::<Vec<_>>().join(" "))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn frame(pipeline: &str, ms: f64) -> Value {
        json!({"pipeline": pipeline, "decal_method": "off", "light_method": "tiled", "shadows": "none",
               "lights": {"tile_size": 16, "aabb": true, "shadow_ray_culling": true, "normals": "improved"},
               "gpu_ms": {"gbuffer": ms, "lighting": 1.0, "total": ms + 1.0}})
    }

    #[test]
    fn runs_are_split_and_their_medians_charted() {
        let mut frames: Vec<Value> = (0..24).map(|i| frame("deferred", if i < 10 { 50.0 } else { 2.0 + (i % 3) as f64 })).collect();
        frames.extend((0..6).map(|i| frame("visbuffer", i as f64)));
        let runs = run_medians(&frames);
        assert_eq!(runs.len(), 2);
        assert!(runs[0].label.starts_with("deferred/off lights=tiled"));
        assert_eq!(runs[0].passes["gbuffer"], 3.0, "warm-up skipped: the median of 2, 3, 4");
        assert_eq!(runs[1].passes["gbuffer"], 4.0, "a short run skips half: the median of 3, 4, 5");
        let dir = std::env::temp_dir().join(format!("charts_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (csv, svg) = write(&dir.join("compare.jsonl"), &runs).unwrap();
        let csv = std::fs::read_to_string(csv).unwrap();
        assert!(csv.starts_with("run,pass,median_ms\n") && csv.lines().count() == 1 + 2 * 3, "{csv}");
        let svg = std::fs::read_to_string(svg).unwrap();
        assert!(svg.contains("<svg") && svg.contains("gbuffer") && svg.contains("visbuffer/off"), "a chart with its labels");
        assert!(!svg.contains("normals=improved"), "words every run shares are left out of the labels");
        assert!(svg.matches("<rect").count() >= 4, "a segment per pass and run");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
