//! `raybatch render`: a picture of a mesh made by the queries themselves, so that a person sees
//! at once that geometry and hits are right, and, with `--shade heat`, where a structure spends
//! its time.
//!
//! One camera ray per pixel through the pixel's centre, from a pinhole camera standing in the
//! `--view` direction from the mesh's centre, far enough for the bounding sphere to fit the
//! vertical field of view, with +Y up (+Z when looking along Y). Each ray's closest hit (the
//! watertight kernel) is shaded by the hit triangle's normal, by its distance, or by the nodes
//! the ray's one-ray walk entered ([`raybatch::AnyAccel::cast_ray_visits`]: misses cost
//! visits too, and show). The image goes out as an 8-bit RGB PNG.

use std::io;

use raybatch::glam::Vec3;
use raybatch::{AccelKind, BuildOptions, Hit, Kernel, Mesh, Ray};
use rayon::prelude::*;

use crate::args::{RenderArgs, Shade};
use crate::error::CliError;
use crate::inputs::{MeshFile, check_cooked_kind, read_mesh_file};
use crate::output::Output;
use crate::progress::{self, Job};
use crate::runner::Measured;

/// Vertical field of view, degrees.
const FOV_DEGREES: f32 = 35.0;
/// Background colour (misses, except in the heat map).
const BACKGROUND: [u8; 3] = [24, 26, 30];

/// Runs the command.
pub fn run(args: &RenderArgs) -> Result<(), CliError> {
    if args.batched && args.shade == Shade::Heat {
        return Err(CliError::usage(
            "--shade heat counts the nodes of the one-ray walk: drop --batched",
        ));
    }
    let output = Output::plan(&args.out, &[&args.mesh])?;
    progress::step(format!("loading {}", args.mesh.display()));
    let (tree, mesh) = match read_mesh_file(&args.mesh)? {
        MeshFile::Obj(mesh) => {
            let kind = args.tree.unwrap_or(AccelKind::DEFAULT);
            progress::step(format!("building {}", kind.name()));
            let tree = kind
                .build(mesh.clone(), &BuildOptions::default())
                .map_err(|e| CliError::input(format!("{}: {e}", args.mesh.display())))?;
            (tree, mesh)
        }
        MeshFile::Cooked(tree, _) => {
            check_cooked_kind(&args.mesh, tree.kind(), args.tree)?;
            let mesh = tree
                .mesh()
                .expect("every kind that cooks keeps its mesh")
                .clone();
            (*tree, mesh)
        }
    };
    let camera = Camera::looking_at(&mesh, Vec3::from_array(args.view), args);
    let rays = camera.rays();
    let pixels = trace(&tree, &rays, args)?;
    let image = shade(&mesh, &rays, &pixels, args.shade);
    progress::done();
    eprintln!("{}", summary(&pixels, tree.kind(), args));
    output.write(|out| write_png(out, args.width, args.height, &image))
}

/// A pinhole camera: where it stands, and the ray direction of each pixel.
struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    width: u32,
    height: u32,
}

impl Camera {
    /// Stands in direction `view` from the mesh's centre, seeing all of its bounding sphere.
    fn looking_at(mesh: &Mesh, view: Vec3, args: &RenderArgs) -> Self {
        let bounds = mesh.bounds();
        let centre = (bounds.min + bounds.max) * 0.5;
        let radius = ((bounds.max - bounds.min) * 0.5)
            .length()
            .max(f32::MIN_POSITIVE);
        let half_fov = (FOV_DEGREES.to_radians() * 0.5).tan();
        let distance = radius / (FOV_DEGREES.to_radians() * 0.5).sin();
        let forward = -view.normalize();
        let sky = if forward.cross(Vec3::Y).length() < 1e-3 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(sky).normalize();
        let up = right.cross(forward);
        Self {
            eye: centre - forward * distance,
            forward,
            right: right * half_fov,
            up: up * half_fov,
            width: args.width,
            height: args.height,
        }
    }

    /// One ray per pixel, row by row from the top.
    fn rays(&self) -> Vec<Ray> {
        let (w, h) = (self.width as f32, self.height as f32);
        let aspect = w / h;
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| {
                let u = (2.0 * (x as f32 + 0.5) / w - 1.0) * aspect;
                let v = 1.0 - 2.0 * (y as f32 + 0.5) / h;
                Ray::new(self.eye, self.forward + self.right * u + self.up * v)
            })
            .collect()
    }
}

/// What a pixel's ray found.
#[derive(Clone, Copy, Default)]
struct Pixel {
    hit: Option<Hit>,
    /// Nodes the walk entered (heat maps only; 0 otherwise).
    visits: u32,
}

/// Answers every camera ray: batched in one call, or per ray in parallel, row by row.
fn trace(tree: &dyn Measured, rays: &[Ray], args: &RenderArgs) -> Result<Vec<Pixel>, CliError> {
    if args.batched {
        progress::step("batched closest hits");
        let mut hits = vec![None; rays.len()];
        tree.cast_ray_batch(rays, &mut hits)
            .map_err(|e| CliError::input(format!("batched query failed: {e}")))?;
        return Ok(hits
            .into_iter()
            .map(|hit| Pixel { hit, visits: 0 })
            .collect());
    }
    let job = Job::start("rendering", u64::from(args.height), "rows");
    let heat = args.shade == Shade::Heat;
    let mut pixels = vec![Pixel::default(); rays.len()];
    let width = args.width as usize;
    pixels
        .par_chunks_mut(width)
        .zip(rays.par_chunks(width))
        .for_each(|(row, rays)| {
            for (pixel, ray) in row.iter_mut().zip(rays) {
                *pixel = if heat {
                    let (hit, visits) = tree.cast_ray_visits(ray, Kernel::Watertight);
                    Pixel { hit, visits }
                } else {
                    Pixel {
                        hit: tree.cast_ray(ray),
                        visits: 0,
                    }
                };
            }
            job.advance();
        });
    job.finish();
    Ok(pixels)
}

/// The RGB bytes of the image.
fn shade(mesh: &Mesh, rays: &[Ray], pixels: &[Pixel], shade: Shade) -> Vec<u8> {
    let (near, far) = depth_range(pixels);
    let most = pixels.iter().map(|p| p.visits).max().unwrap_or(0).max(1);
    let colour = |ray: &Ray, p: &Pixel| match shade {
        Shade::Normal => p.hit.map_or(BACKGROUND, |h| normal(mesh, ray, &h)),
        Shade::Depth => p.hit.map_or(BACKGROUND, |h| depth(h.t, near, far)),
        Shade::Heat => heat(p.visits, most),
    };
    rays.iter()
        .zip(pixels)
        .flat_map(|(ray, pixel)| colour(ray, pixel))
        .collect()
}

/// The hit triangle's normal, turned towards the camera, as a colour (x, y, z to red, green,
/// blue), darkened where the surface turns away from the eye.
fn normal(mesh: &Mesh, ray: &Ray, hit: &Hit) -> [u8; 3] {
    let [a, b, c] = mesh.triangle(hit.triangle);
    let mut n = (b - a).cross(c - a).normalize_or_zero();
    let view = ray.dir.normalize_or_zero();
    if n.dot(view) > 0.0 {
        n = -n;
    }
    let light = 0.35 + 0.65 * n.dot(-view).abs();
    ((n * 0.5 + Vec3::splat(0.5)) * light)
        .to_array()
        .map(unit_to_byte)
}

/// Nearest and farthest hit distance in the image.
fn depth_range(pixels: &[Pixel]) -> (f32, f32) {
    let ts = pixels.iter().filter_map(|p| p.hit.map(|h| h.t));
    ts.fold((f32::INFINITY, 0.0f32), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    })
}

/// Near is bright, far is dark.
fn depth(t: f32, near: f32, far: f32) -> [u8; 3] {
    let span = (far - near).max(f32::MIN_POSITIVE);
    let grey = 1.0 - 0.85 * ((t - near) / span).clamp(0.0, 1.0);
    [unit_to_byte(grey); 3]
}

/// Black for no visit, then blue, cyan, green, yellow and red for the most visits.
fn heat(visits: u32, most: u32) -> [u8; 3] {
    if visits == 0 {
        return [0, 0, 0];
    }
    const RAMP: [[f32; 3]; 5] = [
        [0.05, 0.1, 0.6],
        [0.0, 0.75, 0.9],
        [0.1, 0.85, 0.2],
        [1.0, 0.9, 0.0],
        [0.95, 0.1, 0.05],
    ];
    let x = visits as f32 / most as f32 * (RAMP.len() - 1) as f32;
    let (i, f) = ((x as usize).min(RAMP.len() - 2), x.fract());
    let f = if x >= (RAMP.len() - 1) as f32 { 1.0 } else { f };
    let [a, b] = [RAMP[i], RAMP[i + 1]];
    [0, 1, 2].map(|k| unit_to_byte(a[k] + (b[k] - a[k]) * f))
}

fn unit_to_byte(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// One line for stderr: hits, and the visits the heat map spreads over its colours.
fn summary(pixels: &[Pixel], kind: AccelKind, args: &RenderArgs) -> String {
    let hits = pixels.iter().filter(|p| p.hit.is_some()).count();
    let mut line = format!(
        "render: {}x{} pixels, {hits} hit the mesh ({} tree)",
        args.width,
        args.height,
        kind.name()
    );
    if args.shade == Shade::Heat {
        let total: u64 = pixels.iter().map(|p| u64::from(p.visits)).sum();
        let most = pixels.iter().map(|p| p.visits).max().unwrap_or(0);
        let mean = total as f64 / pixels.len().max(1) as f64;
        line += &format!("; nodes entered per ray: mean {mean:.1}, most {most} (red)");
    }
    line
}

/// Encodes `rgb` (3 bytes per pixel, row by row) as a PNG.
fn write_png(out: &mut dyn io::Write, width: u32, height: u32, rgb: &[u8]) -> io::Result<()> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(io::Error::other)?;
    writer.write_image_data(rgb).map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}
