//! What `raybatch bench` times: the ray sets of a scene, the query columns, and timing a
//! [`Query`] over a ray set (whole, or in consecutive batches) through a [`QueryRunner`].

use raybatch::{Kernel, Mesh, Ray};
use raybatch_tools::scenes::{self, RaySet, SceneKind};

use crate::measure::{Measurement, measure};
use crate::runner::{Engine, Measured, Query, QueryKind, QueryRunner};

/// Timed passes over each ray set; the fastest counts.
pub const PASSES: usize = 2;
/// Seed of every generated ray set.
const RAY_SEED: u64 = 1;

/// One query of the tables: what is asked, of which rays.
#[derive(Clone, Copy, Debug)]
pub struct Column {
    pub kind: QueryKind,
    pub set: RaySet,
}

impl Column {
    const fn new(kind: QueryKind, set: RaySet) -> Self {
        Self { kind, set }
    }

    /// `closest incoherent`, `any short`, ...
    pub fn title(&self) -> String {
        format!("{} {}", self.kind.name(), self.set)
    }

    /// This column's query on one thread with `engine` and the watertight kernel.
    pub fn query(&self, engine: Engine) -> Query {
        Query::new(self.kind, Kernel::Watertight, engine).with_threads(1)
    }
}

/// The query columns of the main tables (and rows of the per-ray vs batched ones), in order.
pub const COLUMNS: [Column; 6] = [
    Column::new(QueryKind::Closest, RaySet::Incoherent),
    Column::new(QueryKind::Closest, RaySet::OutsideIn),
    Column::new(QueryKind::Closest, RaySet::Camera),
    Column::new(QueryKind::Closest, RaySet::Short),
    Column::new(QueryKind::Any, RaySet::LineOfSight),
    Column::new(QueryKind::Any, RaySet::Short),
];

/// The ray sets of one scene, generated once and shared by every tree.
pub struct RaySets {
    sets: Vec<(RaySet, Vec<Ray>)>,
}

impl RaySets {
    /// `count` rays of every set for `mesh`, a scene of `kind`.
    pub fn generate(mesh: &Mesh, kind: SceneKind, count: usize) -> Self {
        let sets = RaySet::ALL
            .into_iter()
            .map(|set| (set, scenes::generate(set, mesh, kind, count, RAY_SEED)))
            .collect();
        Self { sets }
    }

    pub fn get(&self, set: RaySet) -> &[Ray] {
        let found = self.sets.iter().find(|(s, _)| *s == set);
        &found.expect("every ray set is generated").1
    }
}

/// Best of [`PASSES`] runs of `query` over `rays`, all in one call.
pub fn time_query(tree: &dyn Measured, query: Query, rays: &[Ray]) -> Measurement {
    time_in_batches(tree, query, rays, rays.len())
}

/// Best of [`PASSES`] runs of `query` over `rays`, cut into consecutive batches of `batch`
/// rays (the last may be shorter), one call each.
pub fn time_in_batches(
    tree: &dyn Measured,
    query: Query,
    rays: &[Ray],
    batch: usize,
) -> Measurement {
    let query = query.with_batch_size(batch);
    let mut runner =
        QueryRunner::new(tree, query, rays.len()).expect("the benchmark's thread pools start");
    measure(rays, PASSES, &mut runner)
}

/// Mrays/s of `query` over `rays` (see [`time_query`]).
pub fn speed(tree: &dyn Measured, query: Query, rays: &[Ray]) -> f64 {
    time_query(tree, query, rays).mrays_per_s()
}
