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
    /// The tree or mode (`bvh4`, `aabb/pns`, `bvh4 moller-trumbore`, `aabb 16-bit vertices`).
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
