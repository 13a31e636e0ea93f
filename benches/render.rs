//! Rendering speed: an 800 x 800 picture of a field as costly as a 500-constraint variational
//! implicit (a 500-term sum of r^2 log r), of a real 500-constraint variational implicit (a
//! torus solved from surface points and normal offsets; target 2 s), and of a 500k-triangle
//! mesh.

use std::f64::consts::{PI, TAU};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use implicitize::render::{Camera, Coloring, March, Shading, render_field, render_mesh};
use implicitize::{Aabb, DVec3, Field, mesh::Mesh, rbf::Constraint, rbf::Implicit, rbf::Kernel};

/// A bumpy ball: `1 - |p|^2` plus a 500-term thin-plate sum `w r^2 ln r` around points on the
/// unit sphere, so one value costs what a 500-constraint fitted implicit's does. Positive inside.
struct BumpyBall {
    centers: Vec<DVec3>,
    weights: Vec<f64>,
    evaluations: AtomicUsize,
}

impl BumpyBall {
    fn new(n: usize) -> BumpyBall {
        let golden = PI * (3.0 - 5f64.sqrt());
        let centers = (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let a = golden * i as f64;
                DVec3::new(r * a.cos(), r * a.sin(), z)
            })
            .collect();
        let raw: Vec<f64> = (0..n).map(|i| (12.9898 * i as f64).sin()).collect();
        let mean = raw.iter().sum::<f64>() / n as f64;
        let weights = raw.iter().map(|w| 0.05 * (w - mean)).collect();
        BumpyBall { centers, weights, evaluations: AtomicUsize::new(0) }
    }
}

impl Field for BumpyBall {
    fn value(&self, p: DVec3) -> f64 {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let mut sum = 1.0 - p.length_squared();
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let r2 = (p - *c).length_squared();
            if r2 > 0.0 {
                sum += w * 0.5 * r2 * r2.ln();
            }
        }
        sum
    }

    fn gradient(&self, p: DVec3) -> DVec3 {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let mut g = -2.0 * p;
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let d = p - *c;
            let r2 = d.length_squared();
            if r2 > 0.0 {
                g += w * (r2.ln() + 1.0) * d;
            }
        }
        g
    }
}

/// A torus about the y axis (major radius 1, tube radius 0.4) solved from 500 constraints, as
/// the paper's simple method makes them (3.2): 300 points on the surface with value 0, and 100
/// offsets along the normal inside (value +0.1) and 100 outside (value -0.1) at a subset of
/// them. Positive inside.
fn torus_implicit() -> Implicit {
    let (major, minor, offset) = (1.0, 0.4, 0.1);
    let golden = PI * (3.0 - 5f64.sqrt());
    let surface: Vec<(DVec3, DVec3)> = (0..300)
        .map(|i| {
            // Spread over the torus: u steps evenly, v by the golden angle.
            let u = TAU * (i as f64 + 0.5) / 300.0;
            let v = golden * i as f64 * 7.0;
            let normal = DVec3::new(v.cos() * u.cos(), v.sin(), v.cos() * u.sin());
            let centre = DVec3::new(major * u.cos(), 0.0, major * u.sin());
            (centre + minor * normal, normal)
        })
        .collect();
    let mut constraints: Vec<Constraint> =
        surface.iter().map(|(p, _)| Constraint::new(&p.to_array(), 0.0)).collect();
    for (p, n) in surface.iter().step_by(3).take(100) {
        constraints.push(Constraint::new(&(*p - offset * *n).to_array(), offset));
    }
    for (p, n) in surface.iter().skip(1).step_by(3).take(100) {
        constraints.push(Constraint::new(&(*p + offset * *n).to_array(), -offset));
    }
    assert_eq!(constraints.len(), 500);
    Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap()
}

fn uv_sphere(nu: usize, nv: usize) -> Mesh {
    let mut vertices = Vec::new();
    for j in 0..=nv {
        for i in 0..nu {
            let (t, f) = (TAU * i as f64 / nu as f64, PI * j as f64 / nv as f64);
            vertices.push(DVec3::new(f.sin() * t.cos(), f.cos(), f.sin() * t.sin()));
        }
    }
    let id = |i: usize, j: usize| (j * nu + i % nu) as u32;
    let triangles = (0..nv)
        .flat_map(|j| {
            (0..nu).flat_map(move |i| {
                [
                    [id(i, j), id(i + 1, j), id(i + 1, j + 1)],
                    [id(i, j), id(i + 1, j + 1), id(i, j + 1)],
                ]
            })
        })
        .collect();
    Mesh { vertices, triangles }
}

fn bench(c: &mut Criterion) {
    let field = BumpyBall::new(500);
    let bounds = Aabb { min: DVec3::splat(-1.15), max: DVec3::splat(1.15) };
    let camera = Camera::framing(&bounds, 30.0, 20.0, 800, 800).unwrap();
    let start = Instant::now();
    let image = render_field(&field, &bounds, &camera, Coloring::Plain, March::default()).unwrap();
    let covered = image.coverage().iter().filter(|&&c| c).count();
    eprintln!(
        "500-term field, 800 x 800: {:.2} s once, {} exact evaluations for {} covered pixels",
        start.elapsed().as_secs_f64(),
        field.evaluations.load(Ordering::Relaxed),
        covered
    );
    let torus = torus_implicit();
    let torus_bounds = Aabb { min: DVec3::new(-1.5, -0.5, -1.5), max: DVec3::new(1.5, 0.5, 1.5) };
    let torus_camera = Camera::framing(&torus_bounds, 30.0, 30.0, 800, 800).unwrap();
    let start = Instant::now();
    let image =
        render_field(&torus, &torus_bounds, &torus_camera, Coloring::Plain, March::default())
            .unwrap();
    let covered = image.coverage().iter().filter(|&&c| c).count();
    eprintln!(
        "500-constraint torus, 800 x 800: {:.2} s once (target 2 s), {} covered pixels",
        start.elapsed().as_secs_f64(),
        covered
    );
    let mut group = c.benchmark_group("render");
    group.sample_size(10);
    group.bench_function("field_500_terms_800x800", |b| {
        b.iter(|| {
            render_field(black_box(&field), &bounds, &camera, Coloring::Plain, March::default())
                .unwrap()
        })
    });
    group.bench_function("rbf_500_constraints_800x800", |b| {
        b.iter(|| {
            render_field(
                black_box(&torus),
                &torus_bounds,
                &torus_camera,
                Coloring::Plain,
                March::default(),
            )
            .unwrap()
        })
    });
    let mesh = uv_sphere(500, 500);
    let bounds = mesh.bounds().unwrap();
    let camera = Camera::framing(&bounds, 30.0, 20.0, 800, 800).unwrap();
    group.bench_function("mesh_500k_triangles_800x800", |b| {
        b.iter(|| render_mesh(black_box(&mesh), &camera, Coloring::Plain, Shading::Smooth))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
