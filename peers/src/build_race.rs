//! `--build-race R`: the build on every core, Embree's two build qualities against raybatch's
//! default parallel build, timed in turn for R rounds, best kept.
//!
//! Embree builds from the mesh's arrays (it copies them into its own buffers, as a user's first
//! build would); raybatch builds from the shared mesh. Both use every thread of the machine:
//! Embree its own task system, raybatch rayon's global pool.

use std::sync::Arc;
use std::time::{Duration, Instant};

use raybatch::{AccelKind, BuildOptions, Mesh};

use crate::embree_ffi::{
    self as rtc, RTC_BUILD_QUALITY_HIGH, RTC_BUILD_QUALITY_MEDIUM, RTC_SCENE_FLAG_NONE,
};

/// One row of the race: what it builds.
enum Builder {
    Embree {
        quality: rtc::RTCBuildQuality,
        name: &'static str,
    },
    Raybatch(AccelKind),
}

impl Builder {
    fn name(&self) -> String {
        match self {
            Builder::Embree { name, .. } => format!("Embree, quality {name}"),
            Builder::Raybatch(kind) => format!("raybatch `{}`", kind.name()),
        }
    }

    /// Builds once and drops the result; the build's time.
    fn time(&self, device: &rtc::Device, mesh: &Arc<Mesh>) -> Result<Duration, String> {
        let start = Instant::now();
        match self {
            Builder::Embree { quality, .. } => {
                let scene = rtc::Scene::triangles(
                    device,
                    mesh.vertices(),
                    mesh.triangles(),
                    *quality,
                    RTC_SCENE_FLAG_NONE,
                )?;
                let elapsed = start.elapsed();
                drop(scene);
                Ok(elapsed)
            }
            Builder::Raybatch(kind) => {
                let tree = kind
                    .build(mesh.clone(), &BuildOptions::default())
                    .map_err(|e| e.to_string())?;
                let elapsed = start.elapsed();
                drop(tree);
                Ok(elapsed)
            }
        }
    }
}

/// The Markdown table of the race over `mesh`: per row its best build in ms and its time over
/// each Embree quality's.
pub fn build_race(mesh: &Arc<Mesh>, rounds: usize) -> Result<String, String> {
    let device = rtc::Device::new("")?;
    let mut rows = vec![
        Builder::Embree {
            quality: RTC_BUILD_QUALITY_MEDIUM,
            name: "MEDIUM (its default)",
        },
        Builder::Embree {
            quality: RTC_BUILD_QUALITY_HIGH,
            name: "HIGH",
        },
    ];
    let chosen = AccelKind::for_mesh(mesh);
    for kind in [chosen, AccelKind::DEFAULT, AccelKind::Bvh4, AccelKind::Aabb] {
        if !rows
            .iter()
            .any(|r| matches!(r, Builder::Raybatch(k) if *k == kind))
        {
            rows.push(Builder::Raybatch(kind));
        }
    }
    let best = crate::race::best_in_turns(rows.len(), rounds, |k| rows[k].time(&device, mesh))?;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut table = format!(
        "| build, {threads} threads | ms | over Embree MEDIUM | over Embree HIGH |\n\
         |---|---:|---:|---:|\n"
    );
    for (row, time) in rows.iter().zip(&best) {
        table += &format!(
            "| {} | {:.1} | {:.2}x | {:.2}x |\n",
            row.name(),
            ms(*time),
            ms(*time) / ms(best[0]),
            ms(*time) / ms(best[1]),
        );
    }
    Ok(table)
}
