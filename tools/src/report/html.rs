//! The report page: the run's stamp, the charts, and the modes and leaks tables.

use super::charts::Chart;
use super::{Meta, Record, Section};

/// The whole page.
pub fn render(records: &[Record], meta: &Meta, charts: &[Chart]) -> String {
    let mut body = format!(
        "<h1>raybatch bench</h1>\n<p class=\"meta\">{} &middot; commit {} &middot; {} &middot; \
         every row in <a href=\"{}\">{}</a></p>\n",
        escape(&meta.machine),
        escape(&meta.commit),
        escape(&meta.date),
        super::csv::FILE,
        super::csv::FILE,
    );
    for chart in charts {
        body += &format!(
            "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
            chart.file,
            escape(&chart.caption),
            escape(&chart.caption)
        );
    }
    body += &table(
        "Modes: speed, memory and error against the f64 judge",
        records,
        Section::Modes,
    );
    body += &table(
        "Leaks: rays from inside closed meshes aimed at vertices and edges (each must hit)",
        records,
        Section::Leaks,
    );
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>raybatch bench</title>\n\
         <style>body{{font-family:sans-serif;margin:24px;max-width:1300px}}\
         figure{{margin:0 0 28px 0}}img{{max-width:100%;border:1px solid #ddd}}\
         table{{border-collapse:collapse;font-size:13px;margin-bottom:28px}}\
         td,th{{border:1px solid #ccc;padding:3px 7px;text-align:right}}\
         td:nth-child(-n+4),th{{text-align:left}}.meta{{color:#555}}</style>\n\
         </head><body>\n{body}</body></html>\n"
    )
}

/// The rows of `section` as an HTML table (nothing if it has none).
fn table(title: &str, records: &[Record], section: Section) -> String {
    let rows: Vec<&Record> = records.iter().filter(|r| r.section == section).collect();
    if rows.is_empty() {
        return String::new();
    }
    let head = [
        "scene",
        "mode",
        "rays",
        "engine",
        "Mrays/s",
        "bytes/tri",
        "mesh bytes/tri",
        "nodes/ray",
        "judged",
        "hit/miss",
        "missed",
        "wrong tri",
        "ties",
        "max t err",
        "mean t err",
    ];
    let mut out = format!("<h2>{}</h2>\n<table><tr>", escape(title));
    for h in head {
        out += &format!("<th>{h}</th>");
    }
    out += "</tr>\n";
    let num =
        |x: Option<f64>, digits: usize| x.map_or("-".to_string(), |x| format!("{x:.digits$}"));
    let sci = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.1e}"));
    for r in rows {
        let s = r.score;
        let cells = [
            escape(&r.scene),
            escape(&r.mode),
            escape(&r.rays),
            escape(&r.engine),
            num(r.mrays_per_s, 2),
            num(r.bytes_per_triangle, 1),
            num(r.mesh_bytes_per_triangle, 1),
            num(r.nodes_per_ray, 1),
            s.map_or("-".into(), |s| s.rays.to_string()),
            sci(s.map(|s| s.hit_miss_rate())),
            s.map_or("-".into(), |s| s.missed.to_string()),
            sci(s.map(|s| s.wrong_triangle_rate())),
            s.map_or("-".into(), |s| s.ties.to_string()),
            sci(s.map(|s| s.max_t_error)),
            sci(s.map(|s| s.mean_t_error)),
        ];
        out += "<tr>";
        for c in cells {
            out += &format!("<td>{c}</td>");
        }
        out += "</tr>\n";
    }
    out + "</table>\n"
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
