//! Constructive solid geometry on implicit models (paper 1): signs, smooth blends, surfaces,
//! the model file.

use crate::tests::support::models::{ball, disc_2d};
use crate::tests::support::points::random_points;
use crate::tests::support::topology;
use implicitize::model::Model;
use implicitize::shape::Shape;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::{Aabb, DVec3, Field, grid::Grid, grid::Resolution, polygonize};

fn two_balls() -> (Model, Model) {
    (ball(DVec3::ZERO, 1.0, 1.0), ball(DVec3::new(1.1, 0.3, -0.2), 0.7, 3.0))
}

fn combine(op: Operation, blend: f64, a: &Model, b: &Model) -> Composite {
    Composite::new("test", op, blend, vec![Child::from(a.clone()), Child::from(b.clone())]).unwrap()
}

/// The children's values divided by their distance scales.
fn scaled_values(model: &Model, points: &[DVec3]) -> Vec<f64> {
    let s = model.shape().distance_scale();
    model.values(points).into_iter().map(|v| v / s).collect()
}

/// At 100,000 random points where both children are at least `margin` (mesh units) from zero,
/// the composite's sign is the boolean combination of theirs. Returns how many points counted.
fn check_signs(op: Operation, blend: f64, margin: f64) -> usize {
    let (a, b) = two_balls();
    let composite = combine(op, blend, &a, &b);
    let all =
        Aabb { min: a.bounds().min.min(b.bounds().min), max: a.bounds().max.max(b.bounds().max) };
    let points = random_points(&all, 0.5, 100_000, 11);
    let (va, vb) = (scaled_values(&a, &points), scaled_values(&b, &points));
    let values = composite.values(&points);
    let mut counted = 0;
    for i in 0..points.len() {
        if va[i].abs() < margin || vb[i].abs() < margin {
            continue;
        }
        counted += 1;
        let want = op.combine_inside(va[i] > 0.0, vb[i] > 0.0);
        assert_eq!(
            values[i] > 0.0,
            want,
            "{op} (blend {blend}) at {:?}: a = {}, b = {}, composite = {}",
            points[i],
            va[i],
            vb[i],
            values[i]
        );
        assert_eq!(values[i], composite.value(points[i]), "values() agrees with value()");
    }
    counted
}

#[test]
fn sharp_composites_have_the_boolean_combination_of_the_signs() {
    for op in Operation::ALL {
        let counted = check_signs(op, 0.0, 1e-6);
        assert!(counted > 99_000, "{op}: only {counted} points away from the surfaces");
    }
}

#[test]
fn blended_composites_keep_the_signs_away_from_the_fillet() {
    let k = 0.3;
    for op in Operation::ALL {
        let counted = check_signs(op, k, k / 4.0 * 1.0001);
        assert!(counted > 70_000, "{op}: only {counted} points away from the fillet");
    }
}

#[test]
fn a_blended_union_fills_the_crease_and_only_there() {
    let k = 0.3;
    let (a, b) = two_balls();
    let sharp = combine(Operation::Union, 0.0, &a, &b);
    let smooth = combine(Operation::Union, k, &a, &b);
    let points = random_points(&sharp.bounds().unwrap(), 0.5, 100_000, 5);
    let (va, vb) = (scaled_values(&a, &points), scaled_values(&b, &points));
    let (s, f) = (sharp.values(&points), smooth.values(&points));
    let mut filled = 0;
    for i in 0..points.len() {
        assert!(f[i] >= s[i], "a smooth maximum is never below the maximum");
        assert!(f[i] - s[i] <= k / 4.0 + 1e-12, "and at most k/4 above it");
        if f[i] > s[i] {
            assert!((va[i] - vb[i]).abs() < k, "the blend changes only where |a - b| < k");
        }
        if f[i] > 0.0 && s[i] <= 0.0 {
            filled += 1;
            assert!(va[i] > -k && vb[i] > -k, "the fillet is within k of both surfaces");
        }
    }
    assert!(filled > 20, "the fillet adds material at the crease ({filled} points)");
}

#[test]
fn gradients_match_finite_differences_of_the_values() {
    let (a, b) = two_balls();
    let points = random_points(&a.bounds(), 0.5, 300, 3);
    let eps = 1e-6;
    for op in Operation::ALL {
        for blend in [0.0, 0.3] {
            let c = combine(op, blend, &a, &b);
            for &p in &points {
                let g = c.gradient(p);
                let fd = DVec3::new(
                    c.value(p + DVec3::X * eps) - c.value(p - DVec3::X * eps),
                    c.value(p + DVec3::Y * eps) - c.value(p - DVec3::Y * eps),
                    c.value(p + DVec3::Z * eps) - c.value(p - DVec3::Z * eps),
                ) / (2.0 * eps);
                // A sharp operator's gradient jumps where the children are equal; skip those.
                let (va, vb) = (c.children()[0].shape().value(p), c.children()[1].shape().value(p));
                if blend == 0.0
                    && (va / c.children()[0].scale() - vb / c.children()[1].scale()).abs() < 1e-4
                {
                    continue;
                }
                assert!(
                    (g - fd).length() <= 1e-5 * (1.0 + g.length()),
                    "{op} blend {blend} at {p:?}: gradient {g:?}, finite differences {fd:?}"
                );
            }
        }
    }
}

#[test]
fn children_are_brought_to_comparable_scale() {
    let plain = ball(DVec3::new(1.1, 0.3, -0.2), 0.7, 1.0);
    let steep = ball(DVec3::new(1.1, 0.3, -0.2), 0.7, 50.0);
    let (sp, ss) = (plain.shape().distance_scale(), steep.shape().distance_scale());
    assert!((ss / sp - 50.0).abs() < 1e-6 * 50.0, "scales {sp} and {ss}");
    assert!((sp - 1.0).abs() < 0.25, "a ball fitted to distances has slope near 1: {sp}");
    let a = ball(DVec3::ZERO, 1.0, 1.0);
    let points = random_points(&a.bounds(), 0.5, 2000, 8);
    for op in Operation::ALL {
        let x = combine(op, 0.2, &a, &plain).values(&points);
        let y = combine(op, 0.2, &a, &steep).values(&points);
        for (x, y) in x.iter().zip(&y) {
            assert!((x - y).abs() <= 1e-8 * (1.0 + x.abs()), "{op}: {x} against {y}");
        }
    }
}

#[test]
fn the_union_of_two_overlapping_spheres_is_one_closed_surface() {
    let (a, b) = two_balls();
    for blend in [0.0, 0.2] {
        let model = Model::from_composite(combine(Operation::Union, blend, &a, &b)).unwrap();
        let grid = Grid::around(&model.bounds(), Resolution::LongestAxis(48)).unwrap();
        let surface = polygonize::polygonize_field(&model, &grid);
        topology::assert_closed(&surface, "union");
        assert_eq!(topology::components(&surface), 1, "blend {blend}");
        assert_eq!(topology::euler_characteristic(&surface), 2, "a sphere's genus, blend {blend}");
    }
    // The two spheres apart are two surfaces, so the count above can fail.
    let far = ball(DVec3::new(4.0, 0.0, 0.0), 0.7, 1.0);
    let model = Model::from_composite(combine(Operation::Union, 0.0, &a, &far)).unwrap();
    let grid = Grid::around(&model.bounds(), Resolution::LongestAxis(64)).unwrap();
    let surface = polygonize::polygonize_field(&model, &grid);
    topology::assert_closed(&surface, "separate union");
    assert_eq!(topology::components(&surface), 2);
}

#[test]
fn a_difference_cuts_a_dent_and_an_intersection_a_lens() {
    let (a, b) = two_balls();
    for op in [Operation::Difference, Operation::Intersection] {
        let model = Model::from_composite(combine(op, 0.0, &a, &b)).unwrap();
        let grid = Grid::around(&model.bounds(), Resolution::LongestAxis(48)).unwrap();
        let surface = polygonize::polygonize_field(&model, &grid);
        topology::assert_closed(&surface, op.name());
        assert_eq!(topology::components(&surface), 1, "{op}");
        // Values approximate distances in mesh units; the polygonizer refines each vertex in a
        // few steps, which a sharp crease slows down.
        let worst = surface.vertices.iter().map(|&v| model.value(v).abs()).fold(0.0, f64::max);
        assert!(worst < 0.1 * grid.voxel_size, "{op}: a vertex is {worst} off the surface");
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn nested_composites_round_trip_through_the_file() {
    let (a, b) = two_balls();
    let c = ball(DVec3::new(-0.6, 0.0, 0.5), 0.5, 2.0);
    let inner = Model::from_composite(combine(Operation::Difference, 0.1, &a, &b)).unwrap();
    let outer = Model::from_composite(combine(Operation::Union, 0.2, &inner, &c)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (first, second) = (dir.path().join("one.json"), dir.path().join("two.json"));
    outer.save(&first).unwrap();
    let loaded = Model::load(&first).unwrap();
    loaded.save(&second).unwrap();
    assert_eq!(std::fs::read(&first).unwrap(), std::fs::read(&second).unwrap());
    let points = random_points(&outer.bounds(), 0.5, 5000, 4);
    assert_eq!(bits(&outer.values(&points)), bits(&loaded.values(&points)));
    assert_eq!(outer.bounds(), loaded.bounds());
    let Shape::Csg(composite) = loaded.shape() else { panic!("a composite") };
    assert_eq!((composite.operation(), composite.blend()), (Operation::Union, 0.2));
    assert!(matches!(composite.children()[0].shape(), Shape::Csg(_)));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&first).unwrap()).unwrap();
    assert_eq!(json["shape"]["type"], "csg");
    assert_eq!(json["shape"]["op"], "union");
    assert_eq!(json["shape"]["children"][0]["shape"]["op"], "difference");
    assert_eq!(json["shape"]["children"][1]["shape"]["type"], "rbf");
    assert!(json["grid"].is_null());
}

#[test]
fn bad_composites_are_clear_errors() {
    let (a, b) = two_balls();
    let err = |r: Result<Composite, implicitize::Error>| r.unwrap_err().to_string();
    let e = err(Composite::new(
        "x",
        Operation::Union,
        0.0,
        vec![Child::from(a.clone()), Child::from(disc_2d())],
    ));
    assert!(e.contains("3D") && e.contains("2D"), "{e}");
    let e = err(Composite::new("x", Operation::Union, 0.0, vec![Child::from(a.clone())]));
    assert!(e.contains("at least two"), "{e}");
    let e = err(Composite::new(
        "x",
        Operation::Union,
        -1.0,
        vec![Child::from(a.clone()), Child::from(b.clone())],
    ));
    assert!(e.contains("blend"), "{e}");
    let e = Child::with_scale("x", a.shape().clone(), a.bounds(), 0.0).unwrap_err().to_string();
    assert!(e.contains("scale"), "{e}");
    let far = ball(DVec3::new(9.0, 0.0, 0.0), 0.5, 1.0);
    let e = Model::from_composite(combine(Operation::Intersection, 0.0, &a, &far)).unwrap_err();
    assert!(e.to_string().contains("empty"), "{e}");
    // 2D composites work like 2D models.
    let discs = Composite::new(
        "x",
        Operation::Union,
        0.0,
        vec![Child::from(disc_2d()), Child::from(disc_2d())],
    );
    assert_eq!(discs.unwrap().dim(), 2);
}

/// Writes a composite, damages its JSON with `edit`, and returns the load error.
fn load_error_after(
    edit: impl FnOnce(&mut serde_json::Value),
) -> (std::path::PathBuf, String, tempfile::TempDir) {
    let (a, b) = two_balls();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.json");
    Model::from_composite(combine(Operation::Union, 0.0, &a, &b)).unwrap().save(&path).unwrap();
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut json);
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let e = Model::load(&path).unwrap_err().to_string();
    (path, e, dir)
}

#[test]
fn damaged_composite_files_are_named_errors() {
    type Edit = Box<dyn FnOnce(&mut serde_json::Value)>;
    let cases: [(&str, Edit); 5] = [
        ("xor", Box::new(|j| j["shape"]["op"] = "xor".into())),
        ("scale", Box::new(|j| j["shape"]["children"][1]["scale"] = (-2.0).into())),
        (
            "at least two",
            Box::new(|j| {
                j["shape"]["children"].as_array_mut().unwrap().pop();
            }),
        ),
        (
            "csg child 2",
            Box::new(|j| {
                j["shape"]["children"][1]["shape"]["weights"].as_array_mut().unwrap().pop();
            }),
        ),
        ("bounds", Box::new(|j| j["shape"]["children"][0]["bounds"]["min"][0] = 5.0.into())),
    ];
    for (want, edit) in cases {
        let (path, e, _dir) = load_error_after(edit);
        assert!(e.contains(&path.display().to_string()), "names the file: {e}");
        assert!(e.contains(want), "says {want:?}: {e}");
    }
}
