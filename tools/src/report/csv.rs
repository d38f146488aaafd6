//! The report's machine-readable file: one CSV row per [`Record`], RFC 4180 quoting.

use super::{Meta, Record};

/// The file name under the report folder.
pub const FILE: &str = "report.csv";

/// The header, in column order.
pub const COLUMNS: [&str; 21] = [
    "machine",
    "commit",
    "date",
    "section",
    "scene",
    "mode",
    "rays",
    "engine",
    "batch_size",
    "mrays_per_s",
    "bytes_per_triangle",
    "mesh_bytes_per_triangle",
    "nodes_per_ray",
    "judged_rays",
    "hit_miss_rate",
    "missed",
    "extra",
    "wrong_triangle_rate",
    "ties",
    "max_t_error",
    "mean_t_error",
];

/// The whole file: header, then one line per record (empty cells for what a row lacks).
pub fn render(records: &[Record], meta: &Meta) -> String {
    let mut out = COLUMNS.join(",") + "\n";
    for r in records {
        out += &cells(r, meta)
            .iter()
            .map(|c| quote(c))
            .collect::<Vec<_>>()
            .join(",");
        out += "\n";
    }
    out
}

fn cells(r: &Record, meta: &Meta) -> Vec<String> {
    let num = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x}"));
    let int = |x: Option<usize>| x.map_or(String::new(), |x| x.to_string());
    let s = r.score.as_ref();
    vec![
        meta.machine.clone(),
        meta.commit.clone(),
        meta.date.clone(),
        r.section.name().to_string(),
        r.scene.clone(),
        r.mode.clone(),
        r.rays.clone(),
        r.engine.clone(),
        int(r.batch_size),
        num(r.mrays_per_s),
        num(r.bytes_per_triangle),
        num(r.mesh_bytes_per_triangle),
        num(r.nodes_per_ray),
        int(s.map(|s| s.rays)),
        num(s.map(|s| s.hit_miss_rate())),
        int(s.map(|s| s.missed)),
        int(s.map(|s| s.extra)),
        num(s.map(|s| s.wrong_triangle_rate())),
        int(s.map(|s| s.ties)),
        num(s.map(|s| s.max_t_error)),
        num(s.map(|s| s.mean_t_error)),
    ]
}

/// A cell, quoted if it holds a comma, a quote or a line break.
fn quote(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", cell.replace('"', "\"\""))
    } else {
        cell.to_string()
    }
}
