//! [`Scene`]: meshes (each with its own tree), instances of them in the world, the top-level
//! tree over the instances, and the edits a game makes between frames (move an instance,
//! change its layers, deform a mesh).
//!
//! Global triangle ids number the instances' triangles one instance after the other: instance
//! `i`'s triangle `j` is `first_id(i) + j`. A scene answers every query in global ids, so the
//! tie rule "lowest id on equal `t`" reads "lowest instance, then lowest triangle";
//! [`Scene::resolve`] turns a [`Hit`] back into an instance and a triangle.

use glam::Vec3;

use crate::accel::Footprint;
use crate::bvh::BuildOptions;
use crate::catalog::{AccelKind, AnyAccel};
use crate::mesh::{MAX_TRIANGLES, Mesh};
use crate::scene::error::SceneError;
use crate::scene::instance::{Instance, InstanceDesc, world_box};
use crate::scene::refit::refit_mesh;
use crate::scene::rigid::Rigid;
use crate::scene::top::TopTree;

/// Meshes with fewer triangles than this are small for [`Scene::kind_for`].
const SMALL_MESH: usize = 256;

/// Many meshes placed as instances, answering rays in world space (see the module docs and
/// [`crate::scene`]).
#[derive(Debug)]
pub struct Scene {
    pub(crate) meshes: Vec<AnyAccel>,
    pub(crate) instances: Vec<Instance>,
    pub(crate) top: TopTree,
    /// Per instance, its world box and mask, in the arrays the top-level tree reads.
    boxes: Vec<crate::geom::Aabb>,
    masks: Vec<u32>,
}

impl Scene {
    /// A scene of `meshes` placed as `instances` (several may share a mesh). Errors on an
    /// instance of a mesh that does not exist or more triangles than 32-bit ids can number.
    pub fn new(meshes: Vec<AnyAccel>, instances: &[InstanceDesc]) -> Result<Self, SceneError> {
        let mut scene = Self {
            meshes,
            instances: Vec::new(),
            top: TopTree::default(),
            boxes: Vec::new(),
            masks: Vec::new(),
        };
        scene.add_instances(instances)?;
        Ok(scene)
    }

    /// A scene of `meshes` placed as `instances`, each mesh built with the kind the scene picks
    /// for it ([`Scene::kind_for`]), the meshes built in parallel: what a game reaches for
    /// first. Errors as [`Scene::new`], or on a mesh whose tree cannot be built. (A mesh that
    /// will deform needs [`AccelKind::Aabb`] for [`Scene::deform_mesh`]: build it yourself
    /// and use [`Scene::new`].)
    pub fn from_meshes(meshes: Vec<Mesh>, instances: &[InstanceDesc]) -> Result<Self, SceneError> {
        let meshes = crate::parallel::map(true, meshes, |mesh| {
            Self::kind_for(&mesh).build(mesh, &BuildOptions::default())
        });
        Self::new(meshes.into_iter().collect::<Result<_, _>>()?, instances)
    }

    /// The kind [`Scene::from_meshes`] builds `mesh` with: the 4-wide tree for small meshes
    /// (under 256 triangles: a level's boxes, props and vehicles), whose walks
    /// are a level or two deep and where a 4-wide node tests fewer empty slots than an 8-wide
    /// one; [`AccelKind::for_mesh`] otherwise. On the town of the `game_ai_los` example
    /// (meshes of 12 to about 60 triangles) the 4-wide tree answers sightlines about 6% faster
    /// per ray and 2% faster batched than the 8-wide one (docs/benchmarks.md).
    pub fn kind_for(mesh: &Mesh) -> AccelKind {
        if mesh.triangle_count() < SMALL_MESH {
            AccelKind::Bvh4
        } else {
            AccelKind::for_mesh(mesh)
        }
    }

    /// Adds a mesh's structure after the last mesh and returns its index, for instances
    /// added later ([`Scene::add_instances`]): a mesh streamed in during play, or a scene
    /// grown one mesh at a time. No instance of it exists yet, so no answer changes.
    pub fn add_mesh(&mut self, mesh: AnyAccel) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Adds instances after the last one: for what spawns during play (the meshes' trees are
    /// untouched). A few are inserted into the top-level tree, each down one path; more than
    /// an eighth of the scene at once rebuilds it. Returns their indices. Their triangles take
    /// global ids after every id given so far. Errors as [`Scene::new`]; on error nothing
    /// changes. After many insertions, [`Scene::rebuild_top`] restores the top level's speed.
    pub fn add_instances(
        &mut self,
        instances: &[InstanceDesc],
    ) -> Result<std::ops::Range<usize>, SceneError> {
        let mut total = self.triangle_count() as u64;
        for d in instances {
            let meshes = self.meshes.len();
            let mesh = self.meshes.get(d.mesh).ok_or(SceneError::NoSuchMesh {
                mesh: d.mesh,
                meshes,
            })?;
            total += mesh.triangle_count() as u64;
        }
        if total > MAX_TRIANGLES as u64 {
            return Err(SceneError::TooManyTriangles { count: total });
        }
        let start = self.instances.len();
        let mut first_id = self.triangle_count() as u32;
        for d in instances {
            let mesh = &self.meshes[d.mesh];
            let instance = Instance {
                mesh: d.mesh as u32,
                transform: d.transform,
                mask: d.mask,
                user: d.user,
                first_id,
                world_box: world_box(mesh.mesh_bounds(), &d.transform),
                removed: false,
            };
            first_id += mesh.triangle_count() as u32;
            self.boxes.push(instance.world_box);
            self.masks.push(instance.mask);
            self.instances.push(instance);
        }
        let added = start..self.instances.len();
        if added.len() * 8 > self.instances.len() {
            self.rebuild_top();
        } else {
            for instance in added.clone() {
                self.top.insert(instance, &self.boxes, &self.masks);
            }
        }
        Ok(added)
    }

    /// Removes an instance from every query, refitting its path in the top-level tree
    /// (`O(depth)`): for what is destroyed during play. It keeps its index and its global ids
    /// (the other instances keep theirs; ids are never given again), and later edits of it are
    /// refused with [`SceneError::RemovedInstance`]. A removed instance still takes its slot
    /// and its ids: a scene that adds and removes for a long time grows (up to
    /// [`SceneError::TooManyTriangles`]); a new scene over the live instances compacts it.
    pub fn remove_instance(&mut self, instance: usize) -> Result<(), SceneError> {
        self.check_instance(instance)?;
        let removed = &mut self.instances[instance];
        removed.removed = true;
        removed.mask = 0;
        removed.world_box = crate::geom::Aabb::EMPTY;
        self.boxes[instance] = crate::geom::Aabb::EMPTY;
        self.masks[instance] = 0;
        self.top.refit_instance(instance, &self.boxes, &self.masks);
        Ok(())
    }

    /// The meshes.
    pub fn meshes(&self) -> &[AnyAccel] {
        &self.meshes
    }

    /// The instances, by index.
    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// Triangles over all instances (one more than the largest global id).
    pub fn triangle_count(&self) -> usize {
        self.instances.last().map_or(0, |i| {
            i.first_id as usize + self.meshes[i.mesh()].triangle_count()
        })
    }

    /// The instance and mesh triangle of global triangle id `id`, if it exists.
    pub fn locate(&self, id: u32) -> Option<(u32, u32)> {
        if id as usize >= self.triangle_count() {
            return None;
        }
        let after = self.instances.partition_point(|i| i.first_id <= id);
        // Instances of empty meshes share their first id with the next one: take the last
        // instance starting at or before `id`, which owns it.
        let instance = after.checked_sub(1)?;
        Some((instance as u32, id - self.instances[instance].first_id))
    }

    /// Moves one instance and refits the top-level boxes on its path to the root
    /// (`O(depth)`): for a door or a vehicle. On error nothing changes.
    pub fn set_transform(&mut self, instance: usize, transform: Rigid) -> Result<(), SceneError> {
        self.check_instance(instance)?;
        self.place(instance, transform);
        self.top.refit_instance(instance, &self.boxes, &self.masks);
        Ok(())
    }

    /// Moves many instances and refits the whole top level once (`O(instances)`): a frame's
    /// motion. Every index is checked before anything moves; on error nothing changes. The
    /// tree keeps its shape, so after large motions [`Scene::rebuild_top`] restores its speed
    /// (the bench measures both).
    pub fn set_transforms(&mut self, moves: &[(usize, Rigid)]) -> Result<(), SceneError> {
        for &(instance, _) in moves {
            self.check_instance(instance)?;
        }
        for &(instance, transform) in moves {
            self.place(instance, transform);
        }
        self.top.refit(&self.boxes, &self.masks);
        Ok(())
    }

    /// Rebuilds the top-level tree from the instances' current boxes (binned SAH).
    pub fn rebuild_top(&mut self) {
        self.top = TopTree::build(&self.boxes, &self.masks);
    }

    /// Sets an instance's filter layers (see [`crate::scene::SceneView`]).
    pub fn set_mask(&mut self, instance: usize, mask: u32) -> Result<(), SceneError> {
        self.check_instance(instance)?;
        self.instances[instance].mask = mask;
        self.masks[instance] = mask;
        self.top.refit_instance(instance, &self.boxes, &self.masks);
        Ok(())
    }

    /// Sets an instance's user value ([`InstanceDesc::user`]).
    pub fn set_user(&mut self, instance: usize, user: u64) -> Result<(), SceneError> {
        self.check_instance(instance)?;
        self.instances[instance].user = user;
        Ok(())
    }

    /// Bytes the scene adds to its meshes' trees: instances and the top-level tree.
    pub fn scene_bytes(&self) -> usize {
        self.instances.len() * (size_of::<Instance>() + size_of::<u32>() + size_of::<Vec3>() * 2)
            + self.top.heap_bytes()
    }

    /// Refuses an index past the instances, or a removed instance.
    fn check_instance(&self, instance: usize) -> Result<(), SceneError> {
        match self.instances.get(instance) {
            Some(i) if i.removed => Err(SceneError::RemovedInstance { instance }),
            Some(_) => Ok(()),
            None => Err(SceneError::NoSuchInstance {
                instance,
                instances: self.instances.len(),
            }),
        }
    }

    /// Sets an instance's transform and world box (not the top level).
    fn place(&mut self, instance: usize, transform: Rigid) {
        let i = &mut self.instances[instance];
        i.transform = transform;
        i.world_box = world_box(self.meshes[i.mesh()].mesh_bounds(), &transform);
        self.boxes[instance] = i.world_box;
    }

    /// Recomputes the world boxes of every instance of `mesh` and refits the top level.
    fn mesh_moved(&mut self, mesh: usize) {
        for index in 0..self.instances.len() {
            let i = &self.instances[index];
            if i.mesh() == mesh && !i.removed {
                let transform = self.instances[index].transform;
                self.place(index, transform);
            }
        }
        self.top.refit(&self.boxes, &self.masks);
    }

    /// Moves mesh `mesh`'s vertices to `vertices` (same count, same triangles: a deformation)
    /// and refits its tree and every instance of it, without a rebuild. Only meshes built as
    /// [`crate::AccelKind::Aabb`] can be refitted: every box is recomputed from the new
    /// corners, so answers stay exact (a tree far from its build's positions gets slower:
    /// rebuild it then). On error nothing changes.
    pub fn deform_mesh(&mut self, mesh: usize, vertices: Vec<Vec3>) -> Result<(), SceneError> {
        let meshes = self.meshes.len();
        let tree = self
            .meshes
            .get_mut(mesh)
            .ok_or(SceneError::NoSuchMesh { mesh, meshes })?;
        refit_mesh(tree, vertices)?;
        self.mesh_moved(mesh);
        Ok(())
    }
}
