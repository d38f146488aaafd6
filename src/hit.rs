//! What a query finds, the tie rule that makes answers independent of the visiting order, and
//! the one [`Visitor`] interface through which every structure reports hits.
//!
//! **Tie rule.** When several triangles are hit at the same `t` (a ray through a shared edge or
//! vertex, or coplanar overlapping triangles), the closest hit is the one with the **lowest
//! triangle id**. Every structure, ordering, kernel, batch size and thread count follows it, so
//! answers never depend on the order in which a structure visits its triangles. For that,
//! traversal keeps boxes whose entry distance *equals* the current best `t` (they may hold an
//! equal-`t` triangle with a lower id), and a hit replaces the best one when `(t, id)` is
//! lexicographically smaller ([`Hit::is_before`]).

/// A ray's hit on a triangle: `p = origin + t * dir = (1 - u - v) * v0 + u * v1 + v * v2`,
/// where `v0, v1, v2` are the corners of triangle `triangle` in the order the mesh lists them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of its direction (`tmin <= t <= tmax`).
    pub t: f32,
    /// Triangle id: its index in the mesh's triangle array.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second corner.
    pub u: f32,
    /// Barycentric weight of the triangle's third corner.
    pub v: f32,
}

impl Hit {
    /// The tie rule: smaller `t` wins, and on equal `t` the lower triangle id.
    #[inline(always)]
    pub fn is_before(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.triangle < other.triangle)
    }

    /// Sorts hits by `t`, then triangle id (the order `all_hits` returns).
    pub fn sort(hits: &mut [Hit]) {
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    }

    /// The "no hit yet" placeholder of a closest-hit search over `[.., tmax]`: any real hit at
    /// `t <= tmax` is before it (its triangle id is `u32::MAX`, which no mesh uses).
    pub(crate) const fn none_before(tmax: f32) -> Hit {
        Hit {
            t: tmax,
            triangle: NO_TRIANGLE,
            u: 0.0,
            v: 0.0,
        }
    }

    /// `Some(self)` unless this is a [`Hit::none_before`] placeholder.
    pub(crate) fn found(self) -> Option<Hit> {
        (self.triangle != NO_TRIANGLE).then_some(self)
    }
}

/// The triangle id that marks "no hit" (meshes hold fewer triangles, see
/// [`crate::mesh::MAX_TRIANGLES`]).
const NO_TRIANGLE: u32 = u32::MAX;

/// What a query does with each hit. Structures call it for every triangle hit in a ray's
/// current range; the query decides what to keep.
///
/// `ray` is the id the stream gave the ray (0 for a single-ray query; in a batch, its prepared
/// slot, which the batched queries map back to the ray's position). `tmax` is the ray's current
/// range end, owned by the structure: a visitor shrinks it to make the structure skip what lies
/// behind (a closest-hit search sets it to the best `t`), or sets it to `-inf` to end the ray (an
/// any-hit search, or "first N hits"), after which the structure reports nothing more for it.
/// A visitor never raises `tmax`: structures skip what lies behind it as soon as it shrinks.
/// Hits are reported in no particular order; a visitor must not depend on it.
pub trait Visitor {
    /// Called for each hit of ray `ray` with `hit.t <= *tmax`.
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32);

    /// True if [`Visitor::enter_node`] does something. A walk then keeps the tests that only
    /// spare it work, so that the nodes it reports are the ones it needs: the wide trees'
    /// one-ray walk tests the root box first only then (the root node's own test turns away the
    /// same rays, so the built-in queries skip it), and a ray that misses a tree enters none.
    const COUNTS_NODES: bool = false;

    /// True if the visitor may end rays (set `tmax` to [`RAY_DONE`]), as an any-hit search
    /// does at a ray's first hit. The wide trees' stream engine then leaves lists to the
    /// one-ray walk sooner (see `wide::stream`), since ended rays still cost a stream its box
    /// tests until a split drops them. Hits do not depend on it; the nodes a counting visitor
    /// sees ([`Visitor::enter_node`], called only by one-ray walks) do.
    const ENDS_RAYS: bool = false;

    /// Called each time the one-ray walk of ray `ray` enters a node (a tree node or leaf, a
    /// grid cell): the hook behind [`crate::RayQueries::cast_ray_visits`], which draws where a
    /// structure spends its time. The default does nothing, and the built-in queries keep it,
    /// so it compiles to nothing in them. The stream engines call it only for the subtrees
    /// they finish one ray at a time.
    #[inline(always)]
    fn enter_node(&mut self, ray: u32) {
        let _ = ray;
    }
}

/// [`Closest`] that also counts the nodes the walk enters (see [`Visitor::enter_node`]).
pub struct CountingClosest<'a> {
    /// The closest-hit visitor doing the work.
    pub closest: Closest<'a>,
    /// Nodes entered so far.
    pub nodes: u32,
}

impl Visitor for CountingClosest<'_> {
    const COUNTS_NODES: bool = true;

    #[inline(always)]
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        self.closest.visit(ray, hit, tmax);
    }

    #[inline(always)]
    fn enter_node(&mut self, _: u32) {
        self.nodes = self.nodes.saturating_add(1);
    }
}

/// The value of `tmax` that ends a ray (see [`Visitor`]).
pub const RAY_DONE: f32 = f32::NEG_INFINITY;

/// Keeps each ray's closest hit by the tie rule.
pub struct Closest<'a> {
    /// Best hit so far per ray, [`Hit::none_before`] until one is found.
    pub best: &'a mut [Hit],
}

impl Visitor for Closest<'_> {
    #[inline(always)]
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        let best = &mut self.best[ray as usize];
        // `tmax` is always the best `t` so far and structures only report `t <= tmax`, so a
        // strictly smaller `t` wins without reading the best hit (a cache miss in a batch of a
        // million rays); only a tie needs the best hit's id.
        if hit.t < *tmax || hit.is_before(best) {
            *best = hit;
            *tmax = hit.t;
        }
    }
}

/// Marks a ray occluded at its first hit and ends it.
pub struct Any<'a> {
    /// Per ray: has anything been hit.
    pub occluded: &'a mut [bool],
}

impl Visitor for Any<'_> {
    const ENDS_RAYS: bool = true;

    #[inline(always)]
    fn visit(&mut self, ray: u32, _: Hit, tmax: &mut f32) {
        self.occluded[ray as usize] = true;
        *tmax = RAY_DONE;
    }
}

/// Reports every hit of a single ray to an `FnMut`.
pub struct EachHit<F>(pub F);

impl<F: FnMut(Hit)> Visitor for EachHit<F> {
    #[inline(always)]
    fn visit(&mut self, _: u32, hit: Hit, _: &mut f32) {
        (self.0)(hit)
    }
}

/// [`Visitor`] without its constants, so that it can sit behind `&mut dyn` (see [`Keep::Renamed`]).
pub(crate) trait DynVisitor {
    fn visit_dyn(&mut self, ray: u32, hit: Hit, tmax: &mut f32);
    fn enter_node_dyn(&mut self, ray: u32);
}

impl<V: Visitor> DynVisitor for V {
    fn visit_dyn(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        self.visit(ray, hit, tmax);
    }
    fn enter_node_dyn(&mut self, ray: u32) {
        self.enter_node(ray);
    }
}

/// How a renaming [`Sink`] turns a structure's triangle ids into its caller's.
#[derive(Clone, Copy)]
pub(crate) enum Ids<'a> {
    /// The caller's id is the structure's plus an offset (a scene instance's first global id).
    Offset(u32),
    /// The caller's id is `table[id]` (a reordered mesh's original ids).
    Table(&'a [u32]),
}

/// What a [`Sink`] keeps of each hit: one variant per batched query, or a visitor of the
/// caller's behind `&mut dyn`, with the renaming of the adapters that wrap a structure.
pub(crate) enum Keep<'a> {
    /// Each ray's closest hit by the tie rule, and how many hits were reported (what the
    /// batched closest-hit query's choice of grouping reads, `crate::batch::mixing`; one add
    /// per hit).
    Closest { closest: Closest<'a>, reported: u64 },
    /// Whether each ray hit anything; a ray ends at its first hit.
    Any(Any<'a>),
    /// Every hit of ray `ray`, to `f(offset + positions[ray], hit)`.
    Every {
        offset: usize,
        positions: &'a [u32],
        f: &'a (dyn Fn(usize, Hit) + Sync),
    },
    /// A visitor of the caller's, seeing the caller's triangle ids (`ids`) and, for a
    /// sub-stream of the caller's stream, its ray ids (`rays[ray].1`).
    Renamed {
        ids: Ids<'a>,
        rays: Option<&'a [(u32, u32)]>,
        inner: &'a mut dyn DynVisitor,
    },
}

/// The visitor of the stream engines and of the adapters that rename hits (a scene's
/// instances, a structure over a reordered mesh): what to keep ([`Keep`]) chosen at run time,
/// and the constants of [`Visitor`] as parameters. A structure's walks are then compiled for a
/// few such types instead of once per query and per adapter; the cost is a predictable branch
/// per hit (and an indirect call for [`Keep::Renamed`]).
pub(crate) struct Sink<'a, const ENDS_RAYS: bool, const COUNTS_NODES: bool> {
    keep: Keep<'a>,
}

impl<'a> Sink<'a, false, false> {
    /// Keeps each ray's closest hit in `best` (see [`Keep::Closest`]).
    pub(crate) fn closest(best: &'a mut [Hit]) -> Self {
        let closest = Closest { best };
        Self {
            keep: Keep::Closest {
                closest,
                reported: 0,
            },
        }
    }

    /// Reports every hit to `f` (see [`Keep::Every`]).
    pub(crate) fn every(
        offset: usize,
        positions: &'a [u32],
        f: &'a (dyn Fn(usize, Hit) + Sync),
    ) -> Self {
        Self {
            keep: Keep::Every {
                offset,
                positions,
                f,
            },
        }
    }

    /// Hits reported so far to a closest-hit sink (0 for the others).
    pub(crate) fn reported(&self) -> u64 {
        match self.keep {
            Keep::Closest { reported, .. } => reported,
            _ => 0,
        }
    }
}

impl<'a> Sink<'a, true, false> {
    /// Marks each ray occluded at its first hit and ends it (see [`Keep::Any`]).
    pub(crate) fn any(occluded: &'a mut [bool]) -> Self {
        Self {
            keep: Keep::Any(Any { occluded }),
        }
    }
}

impl<const ENDS_RAYS: bool, const COUNTS_NODES: bool> Visitor
    for Sink<'_, ENDS_RAYS, COUNTS_NODES>
{
    const COUNTS_NODES: bool = COUNTS_NODES;
    const ENDS_RAYS: bool = ENDS_RAYS;

    #[inline(always)]
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        match &mut self.keep {
            Keep::Closest { closest, reported } => {
                *reported += 1;
                closest.visit(ray, hit, tmax);
            }
            Keep::Any(any) => any.visit(ray, hit, tmax),
            Keep::Every {
                offset,
                positions,
                f,
            } => f(*offset + positions[ray as usize] as usize, hit),
            Keep::Renamed { ids, rays, inner } => {
                let ray = rays.map_or(ray, |rays| rays[ray as usize].1);
                let triangle = match *ids {
                    Ids::Offset(first) => first + hit.triangle,
                    Ids::Table(table) => table[hit.triangle as usize],
                };
                inner.visit_dyn(ray, Hit { triangle, ..hit }, tmax);
            }
        }
    }

    #[inline(always)]
    fn enter_node(&mut self, ray: u32) {
        if COUNTS_NODES && let Keep::Renamed { rays, inner, .. } = &mut self.keep {
            let ray = rays.map_or(ray, |rays| rays[ray as usize].1);
            inner.enter_node_dyn(ray);
        }
    }
}

/// Work to run with a renaming [`Sink`] (see [`with_renamed`]).
pub(crate) trait RenamedTask {
    type Output;
    fn run<W: Visitor>(self, visitor: &mut W) -> Self::Output;
}

/// Runs `task` with `visitor` behind a [`Sink`] that renames hits by `ids` (and ray ids by
/// `rays`), with `V`'s constants.
#[inline(always)]
pub(crate) fn with_renamed<V: Visitor, T: RenamedTask>(
    ids: Ids<'_>,
    rays: Option<&[(u32, u32)]>,
    visitor: &mut V,
    task: T,
) -> T::Output {
    let keep = Keep::Renamed {
        ids,
        rays,
        inner: visitor,
    };
    // Only the arm of `V`'s constants is compiled for it.
    match (V::ENDS_RAYS, V::COUNTS_NODES) {
        (false, false) => task.run(&mut Sink::<false, false> { keep }),
        (true, false) => task.run(&mut Sink::<true, false> { keep }),
        (false, true) => task.run(&mut Sink::<false, true> { keep }),
        (true, true) => task.run(&mut Sink::<true, true> { keep }),
    }
}
