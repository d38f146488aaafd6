//! The scenes section of `raybatch bench` (`--scenes instanced`): scenes of instances, in the
//! style of PEEL's "SceneRaycastVsStaticMeshes" cases.
//!
//! 1. Per ray vs batched, closest hit, one thread, on two worlds: 16,384 small meshes (the
//!    terrain cut into tiles, each its own mesh and tree) and a few large ones (a terrain and a
//!    rotated city), with short, long and vertical rays.
//! 2. The scene's overhead: the city as one instance at the identity against its bare tree.
//! 3. Keeping the top level current when 10,000 instances move every frame: refit against
//!    rebuild, and the query speed each leaves.
//!
//! Every mesh is built as [`AccelKind::DEFAULT`].

use std::time::Instant;

use raybatch::glam::Vec3;
use raybatch::scene::{InstanceDesc, Rigid, Scene};
use raybatch::{AccelKind, BatchOrdering, BuildOptions, Footprint, Kernel, Ray};
use raybatch_tools::scenes::instanced::{World, WorldRays, large, props, tiles, world_rays, yawed};
use raybatch_tools::scenes::{self, RaySet, SceneKind};

use crate::progress;
use crate::runner::{Engine, Query, QueryKind};
use crate::table::{Align, Table, ratio, thousands};
use crate::workload::{PASSES, speed};

/// The name `--scenes` takes for this section.
pub const NAME: &str = "instanced";

/// Moving instances in the top-level measurement, and the frames timed.
const MOVING: usize = 10_000;
const FRAMES: usize = 20;

/// The whole section, with `rays` rays per ray set.
pub fn section(rays: usize) -> String {
    let tiled = tiles(128, 4);
    let few = large(354, scenes::BUILTIN_CITY_BLOCKS);
    let mut out = format!(
        "### Scenes of instances\n\nClosest hit in Mrays/s, one thread, best of {PASSES} passes \
         over {} rays per set; every mesh is a {} tree. short: 1% of the world's diagonal, long: \
         unbounded, vertical: straight down from above; batched / per-ray: the batched engine \
         (by octant) against one call per ray.\n\n",
        thousands(rays),
        AccelKind::DEFAULT.name()
    );
    let mut table = speed_table();
    for world in [&tiled, &few] {
        speed_rows(world, rays, &mut table);
    }
    out += &table.render();
    out += "\n";
    out += &overhead(rays);
    out += "\n";
    out += &motion(rays.min(200_000));
    out
}

fn per_ray() -> Query {
    Query::new(QueryKind::Closest, Kernel::Watertight, Engine::PerRay).with_threads(1)
}

fn batched() -> Query {
    Query::new(
        QueryKind::Closest,
        Kernel::Watertight,
        Engine::batched(BatchOrdering::ByOctant),
    )
    .with_threads(1)
}

fn speed_table() -> Table {
    let mut table = Table::default();
    for (title, align) in [
        ("world", Align::Left),
        ("instances", Align::Right),
        ("triangles", Align::Right),
        ("build ms", Align::Right),
        ("rays", Align::Left),
        ("per-ray", Align::Right),
        ("batched", Align::Right),
        ("batched / per-ray", Align::Right),
    ] {
        table.column(title, align);
    }
    table
}

/// One row per ray kind for `world`.
fn speed_rows(world: &World, rays: usize, table: &mut Table) {
    progress::step(format!("instanced: building {}", world.name));
    let start = Instant::now();
    let scene = world
        .build(AccelKind::DEFAULT)
        .expect("the built-in worlds build");
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let bounds = world.bounds();
    for kind in WorldRays::ALL {
        progress::step(format!("instanced: {} {} rays", world.name, kind.name()));
        let set = world_rays(kind, &bounds, rays, 5);
        let (one, many) = (
            speed(&scene, per_ray(), &set),
            speed(&scene, batched(), &set),
        );
        table.push(vec![
            world.name.to_string(),
            thousands(world.instances.len()),
            thousands(world.triangle_count()),
            format!("{build_ms:.0}"),
            kind.name().to_string(),
            format!("{one:.2}"),
            format!("{many:.2}"),
            ratio(many / one),
        ]);
    }
}

/// The city as one scene instance at the identity against its bare tree.
fn overhead(rays: usize) -> String {
    progress::step("instanced: scene overhead");
    let city = scenes::city(scenes::BUILTIN_CITY_BLOCKS).mesh;
    let set = scenes::generate(RaySet::Incoherent, &city, SceneKind::City, rays, 6);
    let options = BuildOptions::default();
    let bare = AccelKind::DEFAULT
        .build(city.clone(), &options)
        .expect("the city builds");
    let tree = AccelKind::DEFAULT
        .build(city, &options)
        .expect("the city builds");
    let one =
        Scene::new(vec![tree], &[InstanceDesc::new(0, Rigid::IDENTITY)]).expect("one instance");
    let mut line = format!(
        "Scene overhead, the city ({} triangles) as one instance at the identity vs its bare \
         tree, closest hit on incoherent rays:",
        thousands(bare.triangle_count())
    );
    for (name, query) in [("per-ray", per_ray()), ("batched", batched())] {
        let (b, s) = (speed(&bare, query, &set), speed(&one, query, &set));
        line += &format!(
            " {name} {b:.2} vs {s:.2} Mrays/s ({} of the bare tree);",
            ratio(s / b)
        );
    }
    line.pop();
    line + ".\n"
}

/// 10,000 moving crates: top-level refit against rebuild per frame, and what each leaves.
fn motion(rays: usize) -> String {
    progress::step("instanced: moving instances");
    let world = props(MOVING, 1000.0, 7);
    let mut refitted = world.build(AccelKind::DEFAULT).expect("the props build");
    let mut rebuilt = world.build(AccelKind::DEFAULT).expect("the props build");
    let mut poses: Vec<(f32, Vec3)> = refitted
        .instances()
        .iter()
        .map(|i| (0.0, i.transform().translation()))
        .collect();
    let (mut refit_s, mut rebuild_s) = (0.0, 0.0);
    for frame in 0..FRAMES {
        let moves: Vec<(usize, Rigid)> = poses
            .iter_mut()
            .enumerate()
            .map(|(i, (yaw, at))| {
                let wobble = ((i * 7 + frame * 13) % 11) as f32 / 10.0 - 0.5;
                *yaw += wobble * 0.1;
                *at += Vec3::new(wobble, 0.0, 0.5 - wobble.abs());
                (i, yawed(*yaw, *at))
            })
            .collect();
        let t = Instant::now();
        refitted
            .set_transforms(&moves)
            .expect("the instances exist");
        refit_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        rebuilt.set_transforms(&moves).expect("the instances exist");
        rebuilt.rebuild_top();
        rebuild_s += t.elapsed().as_secs_f64();
    }
    let set: Vec<Ray> = world_rays(WorldRays::Long, &world.bounds(), rays, 8);
    let after_refit = speed(&refitted, batched(), &set);
    let after_rebuild = speed(&rebuilt, batched(), &set);
    let ms = |s: f64| s / FRAMES as f64 * 1e3;
    format!(
        "Moving instances: {} crates all move every frame ({FRAMES} frames). Per frame, \
         set_transforms + refit of the top level {:.2} ms, + rebuild_top {:.2} ms; closest hit \
         afterwards (batched, long rays, {} rays): {after_refit:.2} Mrays/s after the refits, \
         {after_rebuild:.2} after the rebuilds.\n",
        thousands(MOVING),
        ms(refit_s),
        ms(rebuild_s),
        thousands(rays),
    )
}
