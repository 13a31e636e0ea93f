//! Models solved from analytic constraints: balls and a disc.

use implicitize::model::Model;
use implicitize::rbf::{Constraint, Implicit, Kernel};
use implicitize::{Aabb, DVec3};

/// Points spread evenly over the unit sphere (a Fibonacci lattice).
pub fn sphere_directions(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
}

/// A ball solved from analytic constraints: boundary points, the centre inside and a shell of
/// points outside, with signed distances as values multiplied by `value_scale`.
pub fn ball(center: DVec3, radius: f64, value_scale: f64) -> Model {
    let mut constraints: Vec<Constraint> = sphere_directions(80)
        .iter()
        .map(|d| Constraint::new(&(center + *d * radius).to_array(), 0.0))
        .collect();
    constraints.push(Constraint::new(&center.to_array(), radius * value_scale));
    for d in sphere_directions(20) {
        let p = center + d * radius * 1.5;
        constraints.push(Constraint::new(&p.to_array(), -0.5 * radius * value_scale));
    }
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let bounds = Aabb { min: center - DVec3::splat(radius), max: center + DVec3::splat(radius) };
    Model::from_implicit(implicit, bounds, None)
}

/// A disc of radius 1 at the origin in 2D, solved from its boundary and centre.
pub fn disc_2d() -> Model {
    let mut constraints: Vec<Constraint> = (0..24)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 24.0;
            Constraint::new(&[a.cos(), a.sin()], 0.0)
        })
        .collect();
    constraints.push(Constraint::new(&[0.0, 0.0], 1.0));
    let implicit = Implicit::solve(2, Kernel::ThinPlate, &constraints).unwrap();
    let bounds = Aabb { min: DVec3::new(-1.0, -1.0, 0.0), max: DVec3::new(1.0, 1.0, 0.0) };
    Model::from_implicit(implicit, bounds, None)
}
