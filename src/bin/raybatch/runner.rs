//! Answering a whole ray set with one tree: the single place where query engines plug in.
//!
//! A [`QueryRunner`] owns its output buffers, so that timing a pass measures the queries and the
//! writing of their answers, not allocation, and so that every engine is timed doing the same
//! work. Today the only engine is [`Engine::PerRay`]; a batched engine (`tree.cast_rays(&rays,
//! &mut hits)` style) becomes one more variant and one more arm in [`QueryRunner::run`].

use raybatch::{Bvh, Hit, Kernel, Ray, RayQueries};

/// Closest hit or any hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryKind {
    /// `cast_ray`: the nearest hit, with triangle id and barycentrics.
    Closest,
    /// `occluded`: is anything hit at all.
    Any,
}

impl QueryKind {
    pub fn name(self) -> &'static str {
        match self {
            QueryKind::Closest => "closest",
            QueryKind::Any => "any",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        [QueryKind::Closest, QueryKind::Any]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// How the rays are traversed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// One ray at a time through [`RayQueries`].
    PerRay,
}

impl Engine {
    pub fn name(self) -> &'static str {
        match self {
            Engine::PerRay => "per-ray",
        }
    }
}

/// Everything that decides how a ray set is answered, except the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Query {
    pub kind: QueryKind,
    pub kernel: Kernel,
    pub engine: Engine,
}

/// Answers ray sets with one tree and one [`Query`], into buffers it keeps between runs.
pub struct QueryRunner<'t, T: Bvh> {
    tree: &'t T,
    query: Query,
    /// Closest-hit answers of the last run (empty for any-hit queries).
    closest: Vec<Option<Hit>>,
    /// Any-hit answers of the last run (empty for closest-hit queries).
    occluded: Vec<bool>,
}

impl<'t, T: Bvh> QueryRunner<'t, T> {
    /// A runner whose buffers already hold room for `capacity` rays.
    pub fn new(tree: &'t T, query: Query, capacity: usize) -> Self {
        let (closest, occluded) = match query.kind {
            QueryKind::Closest => (Vec::with_capacity(capacity), Vec::new()),
            QueryKind::Any => (Vec::new(), Vec::with_capacity(capacity)),
        };
        Self {
            tree,
            query,
            closest,
            occluded,
        }
    }

    /// Answers `rays` (replacing the previous answers); returns how many rays hit something.
    pub fn run(&mut self, rays: &[Ray]) -> usize {
        let (tree, kernel) = (self.tree, self.query.kernel);
        self.closest.clear();
        self.occluded.clear();
        match (self.query.engine, self.query.kind) {
            (Engine::PerRay, QueryKind::Closest) => {
                let answers = rays.iter().map(|r| tree.cast_ray_with(r, kernel));
                self.closest.extend(answers);
                self.closest.iter().filter(|h| h.is_some()).count()
            }
            (Engine::PerRay, QueryKind::Any) => {
                let answers = rays.iter().map(|r| tree.occluded_with(r, kernel));
                self.occluded.extend(answers);
                self.occluded.iter().filter(|&&o| o).count()
            }
        }
    }

    /// The closest hit of each ray of the last run (closest-hit queries only).
    pub fn closest(&self) -> &[Option<Hit>] {
        &self.closest
    }

    /// Whether each ray of the last run was occluded (any-hit queries only).
    pub fn occluded(&self) -> &[bool] {
        &self.occluded
    }
}
