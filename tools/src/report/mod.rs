//! The report `raybatch bench` writes beside its terminal tables, under
//! `target/raybatch-report/`: every measured row as CSV ([`csv`], with the machine, the commit
//! and the date on every row) and an HTML page with SVG charts ([`charts`], drawn by
//! `plotters`): speed against error, speed against memory, per ray against batched per ray
//! set, and the batch size sweep ([`html`]).

pub mod charts;
pub mod csv;
pub mod html;
mod meta;

use std::path::Path;

pub use meta::Meta;

use crate::judge::Score;

/// Which table a [`Record`] comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// The main table: per-ray speed of every tree.
    Main,
    /// Per ray vs batched, per tree and query.
    Batched,
    /// The batch size sweep.
    Sweep,
    /// The modes: speed, memory and the judge's error figures.
    Modes,
    /// Leaks on closed meshes.
    Leaks,
}

impl Section {
    /// Every section, in report order.
    pub const ALL: [Section; 5] = [
        Section::Main,
        Section::Batched,
        Section::Sweep,
        Section::Modes,
        Section::Leaks,
    ];

    /// The name in the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Section::Main => "main",
            Section::Batched => "batched",
            Section::Sweep => "sweep",
            Section::Modes => "modes",
            Section::Leaks => "leaks",
        }
    }

    /// The section called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// One measured row: a mode (tree, kernel, vertex format) on one ray set with one engine.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The table it comes from.
    pub section: Section,
    /// `bunny`, `terrain`, ... or a closed mesh's name.
    pub scene: String,
    /// The tree or mode (`bvh4`, `aabb/pns`, `bvh8 moller-trumbore`, `aabb 16-bit vertices`).
    pub mode: String,
    /// The query and ray set (`closest incoherent`).
    pub rays: String,
    /// `per-ray`, `batched`, `batched 2 threads`, ...
    pub engine: String,
    /// Rays per call of the batched API (the sweep), if not the whole set.
    pub batch_size: Option<usize>,
    /// Speed, one thread unless the engine says otherwise.
    pub mrays_per_s: Option<f64>,
    /// Bytes per triangle of the structure beside the mesh.
    pub bytes_per_triangle: Option<f64>,
    /// Bytes per triangle of the mesh it reads (positions and indices).
    pub mesh_bytes_per_triangle: Option<f64>,
    /// Nodes visited per ray (the binary trees of the modes table).
    pub nodes_per_ray: Option<f64>,
    /// The judge's figures.
    pub score: Option<Score>,
}

impl Record {
    /// A record with only its names set.
    pub fn new(section: Section, scene: &str, mode: &str, rays: &str, engine: &str) -> Self {
        Self {
            section,
            scene: scene.to_string(),
            mode: mode.to_string(),
            rays: rays.to_string(),
            engine: engine.to_string(),
            batch_size: None,
            mrays_per_s: None,
            bytes_per_triangle: None,
            mesh_bytes_per_triangle: None,
            nodes_per_ray: None,
            score: None,
        }
    }

    /// The same record with its speed.
    pub fn speed(mut self, mrays_per_s: f64) -> Self {
        self.mrays_per_s = Some(mrays_per_s);
        self
    }
}

/// Writes `report.csv`, the charts and `index.html` into `dir` (created if missing); returns
/// the path of the page.
pub fn write(dir: &Path, records: &[Record], meta: &Meta) -> std::io::Result<std::path::PathBuf> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join(csv::FILE), csv::render(records, meta))?;
    let charts = charts::draw_all(dir, records)?;
    let page = dir.join("index.html");
    std::fs::write(&page, html::render(records, meta, &charts))?;
    Ok(page)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Splits one CSV line into cells (RFC 4180 quoting).
    fn parse_line(line: &str) -> Vec<String> {
        let (mut cells, mut cell, mut quoted) = (Vec::new(), String::new(), false);
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    cell.push('"');
                    chars.next();
                }
                ('"', _) => quoted = !quoted,
                (',', false) => cells.push(std::mem::take(&mut cell)),
                _ => cell.push(c),
            }
        }
        cells.push(cell);
        cells
    }

    fn records() -> Vec<Record> {
        let score = Score {
            rays: 1000,
            missed: 3,
            extra: 1,
            wrong_triangle: 2,
            ties: 5,
            max_t_error: 2.5e-7,
            mean_t_error: 1e-8,
        };
        let mut out = Vec::new();
        for (mode, speed, bytes) in [
            ("bvh8 watertight", 4.0, 24.0),
            ("aabb 16-bit vertices", 3.0, 9.0),
        ] {
            for engine in ["per-ray", "batched"] {
                let mut r =
                    Record::new(Section::Modes, "bunny", mode, "closest incoherent", engine)
                        .speed(speed);
                r.bytes_per_triangle = Some(bytes);
                r.mesh_bytes_per_triangle = Some(18.0);
                r.score = Some(score);
                out.push(r);
            }
        }
        out.push(
            Record::new(
                Section::Sweep,
                "bunny",
                "bvh4/pns",
                "closest incoherent",
                "per-ray",
            )
            .speed(2.0),
        );
        for size in [64, 4096] {
            let mut r = Record::new(
                Section::Sweep,
                "bunny",
                "bvh4/pns",
                "closest incoherent",
                "batched",
            )
            .speed(size as f64 / 1000.0);
            r.batch_size = Some(size);
            out.push(r);
        }
        out
    }

    #[test]
    fn writes_csv_charts_and_page_that_read_back() {
        let dir = std::env::temp_dir().join(format!("raybatch-report-test-{}", std::process::id()));
        let meta = Meta {
            machine: "CPU \"X\", 2 cores".into(),
            commit: "abc1234".into(),
            date: "2025-01-02T03:04:05Z".into(),
        };
        let records = records();
        let page = write(&dir, &records, &meta).unwrap();
        let text = std::fs::read_to_string(dir.join(csv::FILE)).unwrap();
        let lines: Vec<Vec<String>> = text.lines().map(parse_line).collect();
        assert_eq!(lines[0], csv::COLUMNS);
        assert_eq!(lines.len(), 1 + records.len());
        let col = |name| csv::COLUMNS.iter().position(|c| *c == name).unwrap();
        for (line, r) in lines[1..].iter().zip(&records) {
            assert_eq!(line.len(), csv::COLUMNS.len());
            assert_eq!(line[col("machine")], meta.machine);
            assert_eq!(line[col("commit")], "abc1234");
            assert_eq!(Section::from_name(&line[col("section")]), Some(r.section));
            assert_eq!(line[col("mode")], r.mode);
            assert_eq!(line[col("mrays_per_s")].parse::<f64>().ok(), r.mrays_per_s);
            assert_eq!(line[col("batch_size")].parse::<usize>().ok(), r.batch_size);
            let max = line[col("max_t_error")].parse::<f64>().ok();
            assert_eq!(max, r.score.map(|s| s.max_t_error));
            let wrong = line[col("wrong_triangle_rate")].parse::<f64>().ok();
            assert_eq!(wrong, r.score.map(|s| s.wrong_triangle_rate()));
        }
        let html = std::fs::read_to_string(&page).unwrap();
        for chart in [
            "speed_vs_error",
            "speed_vs_memory",
            "per_ray_vs_batched",
            "batch_size_sweep",
        ] {
            let svg = std::fs::read_to_string(dir.join(format!("{chart}.svg"))).unwrap();
            assert!(svg.starts_with("<svg") && svg.contains("<circle") | svg.contains("<rect"));
            assert!(html.contains(&format!("src=\"{chart}.svg\"")));
        }
        assert!(html.contains("aabb 16-bit vertices") && html.contains("CPU &quot;X&quot;"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn no_records_no_charts() {
        let dir =
            std::env::temp_dir().join(format!("raybatch-report-empty-{}", std::process::id()));
        let page = write(&dir, &[], &Meta::current()).unwrap();
        assert!(std::fs::read_to_string(page).unwrap().contains("<h1>"));
        assert!(!dir.join("speed_vs_error.svg").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
