//! The comparisons `raybatch bench` prints under a scene's main table: per-ray vs batched
//! (a table per scene), the batch size sweep and the partition kernels (on the bunny only), and
//! the triangle kernels (one line per scene).
//!
//! Every number is Mrays/s of a [`crate::runner::Query`] timed by [`crate::workload`]. The
//! per-ray speeds of the per-ray vs batched table and of the sweep are taken from the main table
//! (the same queries); the one-line comparisons time both sides back to back.

use raybatch::{BatchOrdering, Kernel, PartitionKernel, Ray};
use raybatch_tools::report::{Record, Section};

use crate::progress;
use crate::runner::Measured;
use crate::runner::{Engine, Query, QueryKind};
use crate::table::{Align, Table, mrays, ratio, thousands};
use crate::workload::{COLUMNS, Column, PASSES, RaySets, speed, time_in_batches};

/// Threads of the parallel column of the per-ray vs batched table.
pub const THREADS: usize = 2;

/// Batched closest hits on one thread with `ordering` and `partition`.
fn batched_closest(ordering: BatchOrdering, partition: PartitionKernel) -> Query {
    let engine = Engine::Batched {
        ordering,
        partition,
    };
    Query::new(QueryKind::Closest, Kernel::Watertight, engine).with_threads(1)
}

/// One row of the per-ray vs batched table: a tree and a query column.
pub struct BatchedRow {
    /// `aabb/pns`, ...
    tree: String,
    column: Column,
    per_ray: f64,
    by_octant: f64,
    unordered: f64,
    /// Batched with the faster ordering, on [`THREADS`] threads.
    parallel: f64,
}

impl BatchedRow {
    /// Batched on one thread with the faster ordering.
    fn best(&self) -> f64 {
        self.by_octant.max(self.unordered)
    }

    /// The report's rows: one per engine.
    fn records(&self, scene: &str) -> Vec<Record> {
        let threads = format!("batched {THREADS} threads");
        let engines = [
            ("per-ray", self.per_ray),
            ("batched by-octant", self.by_octant),
            ("batched unordered", self.unordered),
            (threads.as_str(), self.parallel),
        ];
        let title = self.column.title();
        engines
            .map(|(e, m)| Record::new(Section::Batched, scene, &self.tree, &title, e).speed(m))
            .into()
    }

    fn cells(&self) -> Vec<String> {
        vec![
            self.tree.clone(),
            self.column.title(),
            mrays(self.per_ray),
            mrays(self.by_octant),
            mrays(self.unordered),
            mrays(self.parallel),
            ratio(self.best() / self.per_ray),
            ratio(self.parallel / self.best()),
        ]
    }
}

/// A tree under test, and how progress and captions name it.
pub struct Subject<'a> {
    pub scene: &'a str,
    /// `aabb/pns`, ...
    pub label: String,
    pub tree: &'a dyn Measured,
}

impl Subject<'_> {
    fn progress(&self, what: &str) {
        progress::step(format!("{}: {}: {what}", self.scene, self.label));
    }
}

/// Times the batched engine on every column of [`COLUMNS`]; `per_ray` holds the per-ray
/// speeds of the same tree, one per column.
pub fn batched_rows(subject: &Subject, per_ray: &[f64], rays: &RaySets) -> Vec<BatchedRow> {
    COLUMNS
        .iter()
        .zip(per_ray)
        .map(|(&column, &per_ray)| {
            subject.progress(&format!("batched {}", column.title()));
            batched_row(subject, column, per_ray, rays.get(column.set))
        })
        .collect()
}

/// The row of `column`: both orderings on one thread, then the faster on [`THREADS`].
fn batched_row(subject: &Subject, column: Column, per_ray: f64, rays: &[Ray]) -> BatchedRow {
    let tree = subject.tree;
    let batched = |ordering| column.query(Engine::batched(ordering));
    let by_octant = speed(tree, batched(BatchOrdering::ByOctant), rays);
    let unordered = speed(tree, batched(BatchOrdering::Unordered), rays);
    let best = if by_octant >= unordered {
        BatchOrdering::ByOctant
    } else {
        BatchOrdering::Unordered
    };
    let row = BatchedRow {
        tree: subject.label.clone(),
        column,
        per_ray,
        by_octant,
        unordered,
        parallel: speed(tree, batched(best).with_threads(THREADS), rays),
    };
    crate::records::push(row.records(subject.scene));
    row
}

/// The per-ray vs batched section: caption and table.
pub fn batched_section(rows: &[BatchedRow], rays: usize) -> String {
    let caption = format!(
        "Per-ray vs batched, Mrays/s, best of {PASSES} passes over {} rays per set, one thread \
         unless said. per-ray: from the table above; by-octant and unordered: the batched \
         engine with that ordering; {THREADS} threads: batched with the faster of the two, in a \
         rayon pool of {THREADS}; batched / per-ray: the faster ordering on one thread.",
        thousands(rays)
    );
    let mut table = Table::default();
    table.column("tree", Align::Left);
    table.column("query", Align::Left);
    for title in ["per-ray", "by-octant", "unordered"] {
        table.column(title, Align::Right);
    }
    table.column(format!("{THREADS} threads"), Align::Right);
    table.column("batched / per-ray", Align::Right);
    table.column(format!("{THREADS} threads / 1"), Align::Right);
    for row in rows {
        table.push(row.cells());
    }
    format!("{caption}\n\n{}", table.render())
}

/// The batch sizes of the sweep over `n` rays: those of `sizes` below `n`, then `n`.
fn sweep_sizes(sizes: &[usize], n: usize) -> Vec<usize> {
    let mut below: Vec<usize> = sizes.iter().copied().filter(|&s| s < n).collect();
    below.push(n);
    below
}

/// The batch size sweep: batched closest hits on one thread over `rays` cut into consecutive
/// batches of each size, against the per-ray speed (which does not depend on the batch size).
pub fn batch_size_sweep(subject: &Subject, rays: &[Ray], per_ray: f64, sizes: &[usize]) -> String {
    subject.progress("batch size sweep");
    let query = batched_closest(BatchOrdering::ByOctant, PartitionKernel::detect());
    let mut table = Table::default();
    table.column("batch size", Align::Right);
    for title in ["per-ray", "batched", "batched / per-ray"] {
        table.column(title, Align::Right);
    }
    let record = |engine| {
        Record::new(
            Section::Sweep,
            subject.scene,
            &subject.label,
            "closest incoherent",
            engine,
        )
    };
    crate::records::push([record("per-ray").speed(per_ray)]);
    for size in sweep_sizes(sizes, rays.len()) {
        let batched = time_in_batches(subject.tree, query, rays, size).mrays_per_s();
        let mut r = record("batched").speed(batched);
        r.batch_size = Some(size);
        crate::records::push([r]);
        let all = if size == rays.len() { " (all)" } else { "" };
        let ratio = ratio(batched / per_ray);
        let size = format!("{}{all}", thousands(size));
        table.push(vec![size, mrays(per_ray), mrays(batched), ratio]);
    }
    format!(
        "Batch size, closest incoherent on {}, Mrays/s, one thread, by-octant: the {} rays go \
         through `cast_ray_batch_with` in consecutive batches of each size (per-ray: from the table \
         above).\n\n{}",
        subject.label,
        thousands(rays.len()),
        table.render()
    )
}

/// One line comparing the partition kernels for batched closest hits on one thread.
pub fn compare_partitions(subject: &Subject, rays: &[Ray]) -> String {
    subject.progress("comparing partition kernels");
    let (detected, portable) = (PartitionKernel::detect(), PartitionKernel::Portable);
    let speed_of = |partition| {
        let query = batched_closest(BatchOrdering::ByOctant, partition);
        speed(subject.tree, query, rays)
    };
    let (fast, slow) = (speed_of(detected), speed_of(portable));
    format!(
        "Partition kernels, batched closest incoherent on {}, one thread: {} (detected) \
         {fast:.2} Mrays/s, {} {slow:.2} Mrays/s ({} / {} = {}).",
        subject.label,
        detected.name(),
        portable.name(),
        detected.name(),
        portable.name(),
        ratio(fast / slow),
    )
}

/// One line comparing the triangle kernels for per-ray closest hits on one thread.
pub fn compare_kernels(subject: &Subject, rays: &[Ray]) -> String {
    subject.progress("comparing kernels");
    let (watertight, other) = (Kernel::Watertight, Kernel::MollerTrumbore);
    let speed_of = |kernel| {
        let query = Query::new(QueryKind::Closest, kernel, Engine::PerRay).with_threads(1);
        speed(subject.tree, query, rays)
    };
    let (fast, slow) = (speed_of(watertight), speed_of(other));
    format!(
        "Kernels, closest incoherent on {}: {} {fast:.2} Mrays/s, {} {slow:.2} Mrays/s \
         ({} / {} = {}).",
        subject.label,
        watertight.name(),
        other.name(),
        other.name(),
        watertight.name(),
        ratio(slow / fast),
    )
}
