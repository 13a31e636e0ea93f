//! Morphing (paper 1 and 7) between fitted models of different genus: a sphere and a torus.

use std::sync::OnceLock;

use crate::tests::support::meshes::{sphere, torus};
use crate::tests::support::topology;
use implicitize::model::Model;
use implicitize::morph::{self, Method, Morph, MorphOptions, Similarity};
use implicitize::rbf::{Constraint, Implicit, Kernel};
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::{
    Aabb, DVec3, Field, grid::Grid, grid::Resolution, mesh::Mesh, pipeline::MeshFitOptions,
    polygonize,
};

/// Fits `mesh` at a small resolution.
fn fitted(mesh: &Mesh) -> Model {
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(40);
    options.fit.max_iterations = 12;
    implicitize::pipeline::fit_mesh(mesh, &options).unwrap().model
}

/// A sphere of radius 1.5 and a torus of radii 2 and 0.7 around z, both at the origin, fitted
/// once for every test.
fn sphere_and_torus() -> &'static (Model, Model) {
    static MODELS: OnceLock<(Model, Model)> = OnceLock::new();
    MODELS.get_or_init(|| {
        let sphere = fitted(&sphere(DVec3::ZERO, 1.5, 32, 64));
        let torus = fitted(&torus(2.0, 0.7, 96, 48));
        (sphere, torus)
    })
}

/// The fraction of the grid's voxels where `a` and `b` have the same sign.
fn agreement(a: &dyn Field, b: &dyn Field, grid: &Grid) -> f64 {
    let points: Vec<DVec3> = (0..grid.len()).map(|n| grid.position(grid.voxel(n))).collect();
    let (va, vb) = (a.values(&points), b.values(&points));
    let same = va.iter().zip(&vb).filter(|(x, y)| (**x > 0.0) == (**y > 0.0)).count();
    same as f64 / points.len() as f64
}

fn check_morph(method: Method) {
    let (sphere, torus) = sphere_and_torus();
    let options = MorphOptions { method, ..MorphOptions::default() };
    let morph = Morph::new(sphere, torus, &options).unwrap();
    let grid = Grid::around(&morph.bounds(), Resolution::LongestAxis(56)).unwrap();
    let first = agreement(&morph.frame(0.0), sphere, &grid);
    let last = agreement(&morph.frame(1.0), torus, &grid);
    eprintln!("{method:?}: first frame agrees with A on {first}, last with B on {last}");
    assert!(first >= 0.999, "{method:?}: the first frame agrees with A on {first}");
    assert!(last >= 0.999, "{method:?}: the last frame agrees with B on {last}");
    let times = morph::frame_times(6).unwrap();
    let mut inside = Vec::new();
    for &t in &times {
        let surface = polygonize::polygonize_field(&morph.frame(t), &grid);
        topology::assert_closed(&surface, &format!("{method:?} at t = {t}"));
        inside.push(surface);
    }
    let genus_ends = [inside[0].clone(), inside[times.len() - 1].clone()]
        .map(|m| topology::euler_characteristic(&m));
    assert_eq!(genus_ends, [2, 0], "{method:?}: a sphere at the start, a torus at the end");
    // The in-between frames are neither end: the shape moves.
    let middle =
        agreement(&morph.frame(0.5), sphere, &grid).min(agreement(&morph.frame(0.5), torus, &grid));
    assert!(middle < 0.999, "{method:?}: the middle frame is one of the ends ({middle})");
}

#[test]
fn a_blend_morph_turns_a_sphere_into_a_torus() {
    check_morph(Method::Blend);
}

#[test]
fn a_variational_morph_turns_a_sphere_into_a_torus() {
    check_morph(Method::Variational);
}

#[test]
fn the_variational_morph_interpolates_both_ends_constraints() {
    let (sphere, torus) = sphere_and_torus();
    let options = MorphOptions { method: Method::Variational, ..MorphOptions::default() };
    let morph = Morph::new(sphere, torus, &options).unwrap();
    let (implicit, duration) = morph.space_time().unwrap();
    assert_eq!(implicit.dim(), 4);
    assert_eq!(implicit.len(), sphere.implicit().unwrap().len() + torus.implicit().unwrap().len());
    let side = morph.bounds().size().max_element();
    assert!((duration - MorphOptions::default().time_scale * side).abs() < 1e-12 * side);
    let slice = |w: f64| Slice { implicit, w };
    for (model, w) in [(sphere, 0.0), (torus, duration)] {
        for c in model.implicit().unwrap().constraints() {
            let p = DVec3::from_slice(c.position());
            let v = slice(w).value(p);
            if c.value() == 0.0 {
                assert!(v.abs() < 1e-6, "boundary constraint at w = {w}: {v}");
            } else {
                assert_eq!(v > 0.0, c.value() > 0.0, "constraint {c:?} at w = {w}: {v}");
            }
        }
    }
    // Between the constraints the bare slices are close to the ends, so the end correction is
    // small: they agree with A and B on most of the grid.
    let grid = Grid::around(&morph.bounds(), Resolution::LongestAxis(56)).unwrap();
    let first = agreement(&slice(0.0), sphere, &grid);
    let last = agreement(&slice(duration), torus, &grid);
    eprintln!("bare slices: the first agrees with A on {first}, the last with B on {last}");
    assert!(first > 0.99 && last > 0.99, "bare slices agree on {first} and {last}");
}

/// The bare slice of the 4D function at time `w`, without the end correction.
struct Slice<'a> {
    implicit: &'a Implicit,
    w: f64,
}

impl Field for Slice<'_> {
    fn value(&self, p: DVec3) -> f64 {
        self.implicit.value_at(&[p.x, p.y, p.z, self.w])
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        DVec3::from_slice(&self.implicit.gradient_at(&[p.x, p.y, p.z, self.w])[..3])
    }
}

#[test]
fn alignment_moves_and_scales_b_onto_a() {
    let (_, torus) = sphere_and_torus();
    let small = ball_far_away();
    for method in [Method::Blend, Method::Variational] {
        let options = MorphOptions { method, align: true, ..MorphOptions::default() };
        let morph = Morph::new(torus, &small, &options).unwrap();
        let map = morph.placement();
        let expected = Similarity::onto(&small.bounds(), &torus.bounds());
        assert_eq!(map, expected);
        assert!((map.apply(small.bounds().center()) - torus.bounds().center()).length() < 1e-12);
        // The ball is scaled by the ratio of the diagonals, and the frames cover both boxes.
        let moved = map.apply_box(&small.bounds());
        assert!((moved.diagonal() - torus.bounds().diagonal()).abs() < 1e-9);
        assert_eq!(morph.bounds().min, torus.bounds().min.min(moved.min), "{method:?}");
        assert_eq!(morph.bounds().max, torus.bounds().max.max(moved.max), "{method:?}");
        // At t = 1 the frame is the ball moved: the sign at a moved point is the ball's.
        let frame = morph.frame(1.0);
        for p in
            [DVec3::new(10.0, 0.0, 0.0), DVec3::new(10.3, 0.1, 0.0), DVec3::new(10.0, 0.0, 0.45)]
        {
            let q = map.apply(p);
            assert_eq!(frame.value(q) > 0.0, small.value(p) > 0.0, "{method:?} at {p:?}");
        }
    }
}

/// A ball of radius 0.5 at (10, 0, 0), solved from analytic constraints.
fn ball_far_away() -> Model {
    let center = DVec3::new(10.0, 0.0, 0.0);
    let mut constraints = vec![Constraint::new(&center.to_array(), 0.5)];
    for i in 0..60 {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / 60.0;
        let a = 2.4 * i as f64;
        let d = DVec3::new((1.0 - z * z).sqrt() * a.cos(), (1.0 - z * z).sqrt() * a.sin(), z);
        constraints.push(Constraint::new(&(center + d * 0.5).to_array(), 0.0));
        if i % 4 == 0 {
            constraints.push(Constraint::new(&(center + d).to_array(), -0.5));
        }
    }
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let bounds = Aabb { min: center - DVec3::splat(0.5), max: center + DVec3::splat(0.5) };
    Model::from_implicit(implicit, bounds, None)
}

#[test]
fn bad_morphs_are_clear_errors() {
    let (sphere, torus) = sphere_and_torus();
    let e = morph::frame_times(1).unwrap_err().to_string();
    assert!(e.contains("at least 2"), "{e}");
    let disc = Implicit::solve(
        2,
        Kernel::ThinPlate,
        &[
            Constraint::new(&[1.0, 0.0], 0.0),
            Constraint::new(&[0.0, 1.0], 0.0),
            Constraint::new(&[-1.0, 0.0], 0.0),
            Constraint::new(&[0.0, -1.0], 0.0),
            Constraint::new(&[0.0, 0.0], 1.0),
        ],
    )
    .unwrap();
    let disc = Model::from_implicit(
        disc,
        Aabb { min: DVec3::new(-1.0, -1.0, 0.0), max: DVec3::new(1.0, 1.0, 0.0) },
        None,
    );
    let e = Morph::new(sphere, &disc, &MorphOptions::default()).unwrap_err().to_string();
    assert!(e.contains("2D"), "{e}");
    let union = Composite::new(
        "u",
        Operation::Union,
        0.0,
        vec![Child::from(sphere.clone()), Child::from(torus.clone())],
    )
    .unwrap();
    let union = Model::from_composite(union).unwrap();
    let variational = MorphOptions { method: Method::Variational, ..MorphOptions::default() };
    let e = Morph::new(sphere, &union, &variational).unwrap_err().to_string();
    assert!(e.contains("variational") && e.contains("target"), "{e}");
    let e = Morph::new(sphere, torus, &MorphOptions { time_scale: 0.0, ..variational })
        .unwrap_err()
        .to_string();
    assert!(e.contains("time scale"), "{e}");
    // The blend reads any field, composites too.
    assert!(Morph::new(sphere, &union, &MorphOptions::default()).is_ok());
}
