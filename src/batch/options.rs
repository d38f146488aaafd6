//! Options of the batched queries.

use crate::geom::Kernel;

use super::partition::PartitionKernel;

/// How rays of one batch are grouped so that node ordering applies. Every ordering gives the
/// same answers; they differ in speed only.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BatchOrdering {
    /// Group by direction octant and use each node's precomputed order (the default). The
    /// wide trees keep apart only the octants holding a quarter of a chunk and walk the
    /// others' rays together (`Accel::MIXES_SMALL_OCTANTS`: for incoherent rays one long
    /// stream shares more nodes than eight short ones), except for closest-hit rays that
    /// meet far surfaces before their nearest one in a mixed stream: the thread counts the
    /// hits its chunks' walks report per hitting ray, mixed and apart, and walks apart (as
    /// [`Self::SeparateOctants`]) when mixing reports many hits per hit, or, in short chunks,
    /// many more than apart (`batch::mixing` has the rule and the measurements).
    #[default]
    ByOctant,
    /// Group by direction octant, every octant apart however few rays it holds, so that every
    /// ray walks the children of every node nearest first (the wide trees' mixed streams walk
    /// them in slot order). For closest-hit rays that pass many surfaces before the nearest,
    /// such as street-level sightlines in a city (2.3-2.6x the speed of mixed streams there,
    /// docs/benchmarks.md); rays that meet few surfaces (incoherent rays inside an object,
    /// short rays) and any-hit queries are faster mixed. The same as [`Self::ByOctant`] for the
    /// structures that do not mix octants.
    SeparateOctants,
    /// Group by direction octant, and let the structures that mix small octants always mix
    /// them, whatever the hits: [`Self::ByOctant`] without its choice, for measuring the
    /// choice.
    MixedOctants,
    /// One group for all directions, children in fixed order.
    Unordered,
}

impl BatchOrdering {
    /// Every ordering.
    pub const ALL: [BatchOrdering; 4] = [
        BatchOrdering::ByOctant,
        BatchOrdering::SeparateOctants,
        BatchOrdering::MixedOctants,
        BatchOrdering::Unordered,
    ];

    /// Short name for tables and the command line.
    pub fn name(self) -> &'static str {
        match self {
            BatchOrdering::ByOctant => "by-octant",
            BatchOrdering::SeparateOctants => "separate-octants",
            BatchOrdering::MixedOctants => "mixed-octants",
            BatchOrdering::Unordered => "unordered",
        }
    }
}

/// Whether a structure walks a stream's rays side by side, one loop turn each in turn (hiding
/// one ray's cache misses behind the others' work), or shares each node among all the rays
/// that reach it. Only the wide trees with full nodes (`bvh4`, `bvh8`) have both engines; the
/// others ignore it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Interleave {
    /// The structure decides by its size and the stream: a wide tree interleaves when its
    /// nodes, leaf order and mesh pass 16 MiB, where waiting on memory dominates, and for
    /// streams of fewer than 2,048 rays once they pass 8 MiB, where few rays share each node;
    /// but never for a dense octant's stream (one octant holding 3/16 of its chunk: a
    /// camera's coherent rays, which share most nodes) or an octant stream of at least 4,096
    /// rays, nor for a stream of at least 131,072 rays (65,536 for any hit), which shares each
    /// node fetch among many rays.
    #[default]
    Auto,
    /// Always walk rays side by side.
    Always,
    /// Always share nodes among the rays that reach them.
    Never,
}

impl Interleave {
    /// Every choice.
    pub const ALL: [Interleave; 3] = [Interleave::Auto, Interleave::Always, Interleave::Never];

    /// Short name for tables and the command line.
    pub fn name(self) -> &'static str {
        match self {
            Interleave::Auto => "auto",
            Interleave::Always => "always",
            Interleave::Never => "never",
        }
    }
}

/// Options of the batched queries. Every combination gives the same answers; they only change
/// speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BatchOptions {
    /// The ray/triangle kernel.
    pub kernel: Kernel,
    /// How rays are grouped by direction. Structures that walk each ray alone (grids, the
    /// kd-tree: `Accel::GROUP_BY_OCTANT` is false) always get one group; the wide trees get
    /// the octants that hold a quarter of a chunk as their own groups and the others' rays in
    /// one (`Accel::MIXES_SMALL_OCTANTS`), unless the hits that closest-hit chunks report
    /// say that their rays run faster with every octant apart ([`BatchOrdering::ByOctant`]).
    pub ordering: BatchOrdering,
    /// Split large batches over rayon's current thread pool (on the calling thread if no thread
    /// can be started).
    pub parallel: bool,
    /// Batches smaller than this use the single-ray path (still cut into chunks over the
    /// threads, as [`BatchOptions::min_chunk`] says). The default, 2048, sits in the
    /// crossover the bench's batch-size sweep measured on the bunny (batched lost at 64-1k rays
    /// and won from 4k on, one thread).
    pub min_batch: usize,
    /// Smallest chunk handed to one rayon task (default 4,096), except in a batch too small
    /// to give each thread that many rays: it is cut evenly over the threads, in chunks of at
    /// least 512 rays, so that a game frame's few thousand sightlines use every core.
    pub min_chunk: usize,
    /// Largest chunk traversed as one batch; `None` (the default) leaves it to the structure
    /// (65,536 rays for the wide trees, whose chunks walk
    /// incoherent rays as one stream, and 1,048,576 for incoherent rays on a wide tree beyond
    /// the caches (over 16 MiB with its mesh), where every node fetch is a trip to memory;
    /// 1,048,576 for the grids and kd-tree, which take one ray at a time; 131,072 for the
    /// binary trees, which move lanes and walk a stream per direction octant). Bigger chunks
    /// share each node and leaf among more rays; smaller ones keep their rays' records (64
    /// bytes a ray) in the caches: the measured sweeps are at `wide::stream::CHUNK` and
    /// `wide::LARGE_TREE_CHUNK`. A chunk takes about 90 bytes of working memory a ray, which
    /// the thread keeps for its next call (some 6 MiB per thread for the wide trees' chunks,
    /// up to 90 MiB on trees beyond the caches; on several threads chunks are at most half a
    /// thread's share of the batch, see `batch::chunks`).
    pub max_chunk: Option<usize>,
    /// A node reached by fewer rays than this finishes its subtree one ray at a time (the
    /// wide trees' any-hit walks: fewer than twice this, since their streams carry the rays
    /// they have ended; see `wide::stream`).
    pub single_ray_below: usize,
    /// Of those, a node reached by at least this many rays (and at most eight) finishes its
    /// subtree for them together instead, reading each node once for all of them (the packet
    /// walk of the binary trees that ask for it, `Bvh::PACKET_WALK`: the zero-byte and
    /// hybrid trees; on x86-64 CPUs with AVX2, elsewhere one ray at a time). `usize::MAX`
    /// turns it off. The default, 2, cuts the zero-byte tree's batched instructions per ray by
    /// about 12% on incoherent rays (3 or 4 do about as well; docs/benchmarks.md).
    pub packet_from: usize,
    /// Implementation of the box test over many rays ([`PartitionKernel::detect`] by
    /// default); one the CPU lacks is replaced by the portable one.
    pub partition: PartitionKernel,
    /// Rays side by side or nodes shared ([`Interleave::Auto`] by default).
    pub interleave: Interleave,
}

impl Default for BatchOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Watertight,
            ordering: BatchOrdering::ByOctant,
            parallel: true,
            min_batch: 2048,
            min_chunk: 4096,
            max_chunk: None,
            single_ray_below: 8,
            packet_from: 2,
            partition: PartitionKernel::detect(),
            interleave: Interleave::Auto,
        }
    }
}

impl BatchOptions {
    /// With [`BatchOptions::kernel`].
    pub fn with_kernel(mut self, kernel: Kernel) -> Self {
        self.kernel = kernel;
        self
    }
    /// With [`BatchOptions::ordering`].
    pub fn with_ordering(mut self, ordering: BatchOrdering) -> Self {
        self.ordering = ordering;
        self
    }
    /// With [`BatchOptions::parallel`].
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }
    /// With [`BatchOptions::min_batch`].
    pub fn with_min_batch(mut self, min_batch: usize) -> Self {
        self.min_batch = min_batch;
        self
    }
    /// With [`BatchOptions::min_chunk`] (at least 1).
    pub fn with_min_chunk(mut self, min_chunk: usize) -> Self {
        self.min_chunk = min_chunk.max(1);
        self
    }
    /// The smallest and the largest chunk for a structure whose own largest chunk is
    /// `default_largest` ([`crate::accel::Accel::max_chunk`]; both at least 1, the
    /// smallest no larger than the largest).
    pub(crate) fn chunk_bounds(&self, default_largest: usize) -> (usize, usize) {
        let largest = self.max_chunk.unwrap_or(default_largest).max(1);
        (self.min_chunk.clamp(1, largest), largest)
    }

    /// With [`BatchOptions::max_chunk`] (at least 1).
    pub fn with_max_chunk(mut self, max_chunk: usize) -> Self {
        self.max_chunk = Some(max_chunk.max(1));
        self
    }
    /// With [`BatchOptions::single_ray_below`].
    pub fn with_single_ray_below(mut self, rays: usize) -> Self {
        self.single_ray_below = rays;
        self
    }
    /// With [`BatchOptions::packet_from`].
    pub fn with_packet_from(mut self, rays: usize) -> Self {
        self.packet_from = rays;
        self
    }
    /// With [`BatchOptions::interleave`].
    pub fn with_interleave(mut self, interleave: Interleave) -> Self {
        self.interleave = interleave;
        self
    }

    /// With [`BatchOptions::partition`].
    pub fn with_partition(mut self, partition: PartitionKernel) -> Self {
        self.partition = partition;
        self
    }
}
