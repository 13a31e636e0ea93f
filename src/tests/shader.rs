//! `implicitize::shader`: the WGSL of models parses and validates (naga), for every kernel and
//! for composites; the GLSL has the entry points; models the shaders cannot hold are refused.
//! (The GLSL's compilation by glslangValidator and its values on a GPU are tested through the
//! command: crates/implicitize-cli/tests/cli_view.rs and python/tests/test_viewer.py.)

use crate::tests::support::models::{ball, disc_2d, sphere_directions};
use crate::tests::support::wgsl;
use implicitize::model::Model;
use implicitize::rbf::{Constraint, Implicit, Kernel};
use implicitize::shader::{Language, source, texture_source};
use implicitize::shape::Shape;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::{Aabb, DVec3};

/// A unit ball at `center` solved with `kernel`.
fn ball_with(kernel: Kernel, center: DVec3) -> Model {
    let mut constraints: Vec<Constraint> = sphere_directions(40)
        .iter()
        .map(|d| Constraint::new(&(center + *d).to_array(), 0.0))
        .collect();
    constraints.push(Constraint::new(&center.to_array(), 1.0));
    for d in sphere_directions(12) {
        constraints.push(Constraint::new(&(center + d * 1.5).to_array(), -0.5));
    }
    let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
    let bounds = Aabb { min: center - DVec3::ONE, max: center + DVec3::ONE };
    Model::from_implicit(implicit, bounds, None)
}

/// A blended difference of a ball and a union of two others (a tree two levels deep).
fn composite() -> Model {
    let inner = Composite::new(
        "inner",
        Operation::Union,
        0.0,
        vec![
            Child::from(ball_with(Kernel::Cubic, DVec3::new(0.8, 0.0, 0.0))),
            Child::from(ball_with(Kernel::Linear, DVec3::new(-0.8, 0.0, 0.0))),
        ],
    )
    .unwrap();
    let outer = Composite::new(
        "outer",
        Operation::Difference,
        0.2,
        vec![
            Child::from(ball(DVec3::ZERO, 1.5, 1.0)),
            Child::from(Model::from_composite(inner).unwrap()),
        ],
    )
    .unwrap();
    Model::from_composite(outer).unwrap()
}

/// Validates WGSL with naga and checks that it defines the value and gradient functions.
fn check_wgsl(source: &str) {
    let module = wgsl::validate(source);
    let names: Vec<&str> = module.functions.iter().filter_map(|(_, f)| f.name.as_deref()).collect();
    assert!(names.contains(&"implicitize_value") && names.contains(&"implicitize_gradient"));
}

#[test]
fn wgsl_of_every_kernel_validates() {
    for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
        let wgsl = source(&ball_with(kernel, DVec3::ZERO), "ball.json", Language::Wgsl).unwrap();
        assert!(wgsl.contains(&format!("implicitize_phi_{}", kernel.name())));
        check_wgsl(&wgsl);
    }
}

#[test]
fn wgsl_of_a_nested_blended_composite_validates() {
    let wgsl = source(&composite(), "csg.json", Language::Wgsl).unwrap();
    assert!(wgsl.contains("implicitize_combine"));
    check_wgsl(&wgsl);
}

#[test]
fn the_header_states_the_sign_units_and_bounds() {
    let model = ball(DVec3::new(10.0, 0.0, 0.0), 2.0, 1.0);
    for language in [Language::Glsl, Language::Wgsl] {
        let text = source(&model, "ball.json", language).unwrap();
        let header: String = text.lines().take_while(|l| l.starts_with("//")).collect();
        assert!(header.contains("positive inside"), "{header}");
        assert!(header.contains("mesh's own units"), "{header}");
        assert!(
            header.contains("min (8, -2, -2)") && header.contains("max (12, 2, 2)"),
            "{header}"
        );
    }
}

#[test]
fn the_texture_holds_every_centre_of_a_composite_in_tree_order() {
    let model = composite();
    let (glsl, texture) = texture_source(&model, "csg.json").unwrap();
    assert!(glsl.contains("uniform highp sampler2D implicitize_centres;"));
    assert!(!glsl.contains("const vec4 IMPLICITIZE_RBF"));
    assert_eq!(texture.width, 1024, "the module doc's texels per row");
    assert_eq!(texture.texels.len(), 4 * texture.width * texture.height);
    // Three balls: 80 + 1 + 20 centres, then 40 + 1 + 12 twice; the second starts at 101.
    assert!(glsl.contains("(j + 0)") && glsl.contains("(j + 101)") && glsl.contains("(j + 154)"));
    let Shape::Csg(outer) = model.shape() else { panic!("a composite") };
    let first = outer.children()[0].shape().implicit().expect("the first child is a ball");
    let weight = first.weights()[3] as f32;
    assert_eq!(texture.texels[4 * 3 + 3], weight);
    assert!(texture.texels[4 * 207..].iter().all(|&x| x == 0.0), "padding is zero");
}

#[test]
fn a_2d_model_is_refused_with_its_name() {
    let error = source(&disc_2d(), "disc.json", Language::Glsl).unwrap_err().to_string();
    assert!(error.contains("disc.json") && error.contains("2D"), "{error}");
}
