//! Where `raybatch bench` collects the rows of its report while it prints its tables.
//!
//! The tables are built deep in several modules (main table, per ray vs batched, sweep,
//! modes); one process-wide list lets each add its rows where it measures them, without
//! threading a collector through every signature. [`write_report`] drains it at the end.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use raybatch_tools::report::{self, Meta, Record};

static RECORDS: Mutex<Vec<Record>> = Mutex::new(Vec::new());

/// Adds rows to the report.
pub fn push(records: impl IntoIterator<Item = Record>) {
    let mut list = RECORDS.lock().unwrap_or_else(|e| e.into_inner());
    list.extend(records);
}

/// The report folder: `target/raybatch-report` under the current directory, or under
/// `CARGO_TARGET_DIR` if set.
pub fn report_dir() -> PathBuf {
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| "target".into(), PathBuf::from);
    target.join("raybatch-report")
}

/// Writes every collected row to `dir` (CSV, charts, HTML); returns the page's path.
pub fn write_report(dir: &Path) -> std::io::Result<PathBuf> {
    let records = std::mem::take(&mut *RECORDS.lock().unwrap_or_else(|e| e.into_inner()));
    report::write(dir, &records, &Meta::current())
}
