//! Scenes in cooked files: each mesh's structure, then the instances.
//!
//! ```text
//! meshes     count, then per mesh: kind number, mesh, body (as a structure's payload)
//! instances  count, then per instance: mesh (u32), rotation x y z w, translation x y z,
//!            scale (f32 each), mask (u32), user (u64), removed (u32: 0 or 1)
//! ```
//! Loading makes the scene anew from its meshes and instances, then removes the removed ones
//! (so every instance keeps its index and its triangles their global ids). Its top-level tree
//! is built anew: answers do not depend on that tree's shape (the tie rule).

use std::path::Path;

use glam::{Quat, Vec3};

use super::{CookError, Reader, SCENE, Writer, file, payload, read_structure, write_structure};
use crate::scene::{InstanceDesc, Rigid, Scene};

impl Scene {
    /// The scene as a cooked file's bytes (see [`crate::cook`]): every mesh's structure and
    /// every instance (removed ones too, so that ids stay). [`CookError::Unsupported`] if a
    /// mesh's kind does not cook.
    pub fn to_cooked(&self) -> Result<Vec<u8>, CookError> {
        let mut out = Writer::default();
        out.count(self.meshes().len())?;
        for structure in self.meshes() {
            write_structure(&mut out, structure)?;
        }
        out.count(self.instances().len())?;
        for instance in self.instances() {
            write_instance(&mut out, instance);
        }
        Ok(file(SCENE, out.into_bytes()))
    }

    /// The scene of a cooked file's bytes, answering bit for bit as the one saved (errors as
    /// [`crate::AnyAccel::from_cooked`]'s, and [`CookError::Scene`] for a bad instance).
    pub fn from_cooked(bytes: &[u8]) -> Result<Self, CookError> {
        let (content, payload) = payload(bytes)?;
        if content != SCENE {
            return Err(CookError::WrongContent {
                expected: "scene",
                found: "structure",
            });
        }
        let mut body = Reader::new(payload);
        let meshes = (0..body.count(4)?)
            .map(|_| read_structure(&mut body))
            .collect::<Result<Vec<_>, _>>()?;
        let instances = (0..body.count(INSTANCE_BYTES)?)
            .map(|_| read_instance(&mut body))
            .collect::<Result<Vec<_>, _>>()?;
        body.finish()?;
        let descs: Vec<InstanceDesc> = instances.iter().map(|&(desc, _)| desc).collect();
        let mut scene = Scene::new(meshes, &descs).map_err(CookError::Scene)?;
        for (index, &(_, removed)) in instances.iter().enumerate() {
            if removed {
                scene.remove_instance(index).map_err(CookError::Scene)?;
            }
        }
        Ok(scene)
    }

    /// Writes [`Scene::to_cooked`] to `path`.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), CookError> {
        Ok(std::fs::write(path, self.to_cooked()?)?)
    }

    /// Reads the scene cooked in `path` ([`Scene::from_cooked`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, CookError> {
        Self::from_cooked(&std::fs::read(path)?)
    }
}

/// Bytes of one instance.
const INSTANCE_BYTES: usize = 4 + 4 * 8 + 4 + 8 + 4;

fn write_instance(out: &mut Writer, instance: &crate::scene::Instance) {
    let transform = instance.transform();
    out.u32(instance.mesh() as u32);
    transform
        .rotation()
        .to_array()
        .into_iter()
        .for_each(|c| out.f32(c));
    transform
        .translation()
        .to_array()
        .into_iter()
        .for_each(|c| out.f32(c));
    out.f32(transform.scale());
    out.u32(instance.mask());
    out.u64(instance.user());
    out.u32(u32::from(instance.is_removed()));
}

/// An instance written by [`write_instance`], and whether it was removed.
fn read_instance(body: &mut Reader) -> Result<(InstanceDesc, bool), CookError> {
    let mesh = body.u32()? as usize;
    let mut floats = [0.0; 8];
    for f in &mut floats {
        *f = body.f32()?;
    }
    let rotation = Quat::from_array([floats[0], floats[1], floats[2], floats[3]]);
    let translation = Vec3::new(floats[4], floats[5], floats[6]);
    let transform =
        Rigid::from_cooked(rotation, floats[7], translation).map_err(CookError::Scene)?;
    let (mask, user) = (body.u32()?, body.u64()?);
    let removed = match (body.u32()?, mask) {
        (0, _) => false,
        (1, 0) => true,
        (1, _) => return Err(CookError::Corrupt("a removed instance on layers")),
        _ => return Err(CookError::Corrupt("removed is neither 0 nor 1")),
    };
    let desc = InstanceDesc::new(mesh, transform)
        .with_mask(mask)
        .with_user(user);
    Ok((desc, removed))
}
