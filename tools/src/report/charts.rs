//! The report's charts, drawn as SVG by `plotters`: one function per chart, each reading the
//! records it needs and skipping itself (returning `None`) when there are none.

use std::io;
use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use super::{Record, Section};

/// Size of every chart, in pixels.
const SIZE: (u32, u32) = (900, 520);
/// The mode whose per-ray vs batched speeds are charted.
pub const DEFAULT_MODE: &str = "bvh8 watertight";
/// The ray set of the speed/error and speed/memory charts.
pub const CHART_RAYS: &str = "closest incoherent";

/// A chart written to the report folder: its file name and caption.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chart {
    /// File name, `*.svg`.
    pub file: String,
    /// What it shows, one sentence (the page's caption).
    pub caption: String,
}

/// Draws every chart that has data into `dir`.
pub fn draw_all(dir: &Path, records: &[Record]) -> io::Result<Vec<Chart>> {
    let charts = [
        speed_vs_error(dir, records)?,
        speed_vs_memory(dir, records)?,
        per_ray_vs_batched(dir, records)?,
        batch_size_sweep(dir, records)?,
    ];
    Ok(charts.into_iter().flatten().collect())
}

fn io_error(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(e.to_string())
}

/// The modes' per-ray records on [`CHART_RAYS`] of the first scene that has modes.
fn mode_points(records: &[Record]) -> Vec<&Record> {
    let modes = || records.iter().filter(|r| r.section == Section::Modes);
    let Some(scene) = modes().next().map(|r| &r.scene) else {
        return Vec::new();
    };
    modes()
        .filter(|r| &r.scene == scene && r.rays == CHART_RAYS && r.engine == "per-ray")
        .filter(|r| r.mrays_per_s.is_some())
        .collect()
}

/// Width of the legend column right of a scatter.
const LEGEND_WIDTH: u32 = 230;

/// A scatter of one point per mode, named in a legend column right of the plot (inside the
/// plot, labels would cover points or be clipped at its edge).
fn scatter<X>(
    path: &Path,
    title: &str,
    x_desc: &str,
    x_range: X,
    x_format: &dyn Fn(&f64) -> String,
    points: &[(String, f64, f64)],
) -> io::Result<()>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(io_error)?;
    let (plot, legend) = root.split_horizontally(SIZE.0 - LEGEND_WIDTH);
    let top = points.iter().map(|p| p.2).fold(0.0, f64::max) * 1.15;
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(x_range, 0.0..top.max(1e-3))
        .map_err(io_error)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .x_labels(8)
        .x_label_formatter(x_format)
        .y_desc("Mrays/s (one thread, per ray)")
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(io_error)?;
    for (i, (name, x, y)) in points.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series([Circle::new((*x, *y), 7, color.filled())])
            .map_err(io_error)?;
        let row = 70 + 26 * i as i32;
        legend
            .draw(&Circle::new((14, row), 7, color.filled()))
            .map_err(io_error)?;
        legend
            .draw(&Text::new(name.clone(), (28, row - 8), ("sans-serif", 15)))
            .map_err(io_error)?;
    }
    root.present().map_err(io_error)
}

/// `[10^floor(log10 lo), 10^ceil(log10 hi)]` around positive values.
fn decades(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() {
        return (1e-9, 1.0);
    }
    let lo = 10f64.powf(lo.log10().floor());
    let hi = 10f64.powf(hi.log10().ceil()).max(lo * 10.0);
    (lo, hi)
}

/// Smallest error the log axis shows: errors below (an exact hit's `t` is within `f32`
/// rounding, about 1e-7) are drawn at it.
const ERROR_FLOOR: f64 = 1e-9;

fn speed_vs_error(dir: &Path, records: &[Record]) -> io::Result<Option<Chart>> {
    let points: Vec<(String, f64, f64)> = mode_points(records)
        .iter()
        .filter_map(|r| {
            let s = r.score?;
            Some((
                r.mode.clone(),
                s.max_t_error.max(ERROR_FLOOR),
                r.mrays_per_s?,
            ))
        })
        .collect();
    if points.is_empty() {
        return Ok(None);
    }
    let scene = &mode_points(records)[0].scene;
    let (lo, hi) = decades(points.iter().map(|p| p.1));
    let file = "speed_vs_error.svg";
    scatter(
        &dir.join(file),
        &format!("Speed against error ({scene}, {CHART_RAYS})"),
        "largest t error vs the f64 judge, relative to max(|t|, |origin|) (log)",
        (lo..hi).log_scale(),
        &|x: &f64| format!("{x:.0e}"),
        &points,
    )?;
    Ok(Some(Chart {
        file: file.to_string(),
        caption: format!(
            "Each mode's per-ray speed against its largest relative error of t on {scene} \
             ({CHART_RAYS}); errors below {ERROR_FLOOR:e} are drawn at it."
        ),
    }))
}

fn speed_vs_memory(dir: &Path, records: &[Record]) -> io::Result<Option<Chart>> {
    let points: Vec<(String, f64, f64)> = mode_points(records)
        .iter()
        .filter_map(|r| {
            let bytes = r.bytes_per_triangle? + r.mesh_bytes_per_triangle?;
            Some((r.mode.clone(), bytes, r.mrays_per_s?))
        })
        .collect();
    if points.is_empty() {
        return Ok(None);
    }
    let scene = &mode_points(records)[0].scene;
    let right = points.iter().map(|p| p.1).fold(0.0, f64::max) * 1.1;
    let file = "speed_vs_memory.svg";
    scatter(
        &dir.join(file),
        &format!("Speed against memory ({scene}, {CHART_RAYS})"),
        "bytes per triangle: structure + mesh (positions and indices)",
        0.0..right,
        &|x: &f64| format!("{x:.0}"),
        &points,
    )?;
    Ok(Some(Chart {
        file: file.to_string(),
        caption: format!(
            "Each mode's per-ray speed against the bytes per triangle it reads: its structure \
             plus the mesh (12-byte f32 positions, or 6/4/3-byte quantized ones, and indices), \
             on {scene}."
        ),
    }))
}

fn per_ray_vs_batched(dir: &Path, records: &[Record]) -> io::Result<Option<Chart>> {
    let mine: Vec<&Record> = records
        .iter()
        .filter(|r| r.section == Section::Modes && r.mode == DEFAULT_MODE)
        .collect();
    let Some(scene) = mine.first().map(|r| r.scene.clone()) else {
        return Ok(None);
    };
    let speed = |set: &str, engine: &str| {
        mine.iter()
            .find(|r| r.scene == scene && r.rays == set && r.engine == engine)
            .and_then(|r| r.mrays_per_s)
    };
    let mut sets: Vec<&str> = Vec::new();
    for r in mine.iter().filter(|r| r.scene == scene) {
        if !sets.contains(&r.rays.as_str()) {
            sets.push(&r.rays);
        }
    }
    let bars: Vec<(f64, f64)> = sets
        .iter()
        .map(|s| {
            (
                speed(s, "per-ray").unwrap_or(0.0),
                speed(s, "batched").unwrap_or(0.0),
            )
        })
        .collect();
    let top = bars.iter().map(|b| b.0.max(b.1)).fold(0.0, f64::max) * 1.15;
    let file = "per_ray_vs_batched.svg";
    let path = dir.join(file);
    let root = SVGBackend::new(&path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(io_error)?;
    let n = sets.len() as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Per ray vs batched ({scene}, {DEFAULT_MODE})"),
            ("sans-serif", 22),
        )
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..n - 0.5, 0.0..top.max(1e-3))
        .map_err(io_error)?;
    let names: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(sets.len())
        .x_label_formatter(&|x: &f64| category(&names, *x))
        .y_desc("Mrays/s (one thread)")
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(io_error)?;
    for (engine, color, offset) in [("per ray", BLUE, -0.38), ("batched", RED, 0.02)] {
        let rects = bars.iter().enumerate().map(move |(i, b)| {
            let v = if offset < 0.0 { b.0 } else { b.1 };
            let x = i as f64 + offset;
            Rectangle::new([(x, 0.0), (x + 0.36, v)], color.filled())
        });
        chart
            .draw_series(rects)
            .map_err(io_error)?
            .label(engine)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], color.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(io_error)?;
    Ok(Some(Chart {
        file: file.to_string(),
        caption: format!(
            "Closest hit per ray and batched (by octant, one thread) on each ray set of {scene}, \
             {DEFAULT_MODE}."
        ),
    }))
}

/// Draws the chart's series legend at `position`.
fn legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> io::Result<()>
where
    DB: DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .label_font(("sans-serif", 15))
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()
        .map_err(io_error)
}

/// The name of category `x` (an integer position), or nothing between categories.
fn category(names: &[String], x: f64) -> String {
    let i = x.round();
    if (x - i).abs() > 1e-6 || i < 0.0 {
        return String::new();
    }
    let name = names.get(i as usize).map_or("", |s| s.as_str());
    name.strip_prefix("closest ").unwrap_or(name).to_string()
}

fn batch_size_sweep(dir: &Path, records: &[Record]) -> io::Result<Option<Chart>> {
    let sweep: Vec<&Record> = records
        .iter()
        .filter(|r| r.section == Section::Sweep)
        .collect();
    let points: Vec<(f64, f64)> = sweep
        .iter()
        .filter_map(|r| Some((r.batch_size? as f64, r.mrays_per_s?)))
        .collect();
    let per_ray = sweep
        .iter()
        .find(|r| r.engine == "per-ray")
        .and_then(|r| r.mrays_per_s);
    let (Some(first), Some(per_ray)) = (sweep.first(), per_ray) else {
        return Ok(None);
    };
    if points.is_empty() {
        return Ok(None);
    }
    let right = points.iter().map(|p| p.0).fold(1.0, f64::max) * 2.0;
    let top = points.iter().map(|p| p.1).fold(per_ray, f64::max) * 1.15;
    let file = "batch_size_sweep.svg";
    let path = dir.join(file);
    let root = SVGBackend::new(&path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(io_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Batch size ({}, {}, {})",
                first.scene, first.mode, first.rays
            ),
            ("sans-serif", 22),
        )
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d((32.0..right).log_scale(), 0.0..top)
        .map_err(io_error)?;
    chart
        .configure_mesh()
        .x_desc("rays per call of the batched API (log)")
        .y_desc("Mrays/s (one thread)")
        .x_label_formatter(&|x: &f64| format!("{}", *x as u64))
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(io_error)?;
    chart
        .draw_series(LineSeries::new(points.iter().copied(), RED.stroke_width(2)))
        .map_err(io_error)?
        .label("batched")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RED.stroke_width(2)));
    chart
        .draw_series(points.iter().map(|&p| Circle::new(p, 5, RED.filled())))
        .map_err(io_error)?;
    chart
        .draw_series(LineSeries::new(
            [(32.0, per_ray), (right, per_ray)],
            BLUE.stroke_width(2),
        ))
        .map_err(io_error)?
        .label("per ray")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLUE.stroke_width(2)));
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(io_error)?;
    Ok(Some(Chart {
        file: file.to_string(),
        caption: format!(
            "Batched closest hits on {} with the rays passed in calls of each size, against \
             per ray (one thread).",
            first.scene
        ),
    }))
}
