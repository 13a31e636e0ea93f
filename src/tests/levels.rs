//! Detail levels over the paper's fit: a deliberately coarse level 0 of a torus corrected by
//! levels below the target, local evaluation against the sum over every centre, the model
//! file's version 2, the shaders that read levels and the consumers that refuse them.

use std::sync::OnceLock;

use crate::tests::support::meshes::{max_vertex_distance, torus};
use crate::tests::support::points::random_points;
use implicitize::batch::{self, BatchOptions};
use implicitize::fit::{FitOptions, LevelsStop, Termination};
use implicitize::morph::{self, Morph, MorphOptions};
use implicitize::pipeline::{self, Fitted, MeshFitOptions};
use implicitize::rbf::MultiScale;
use implicitize::shader::{self, Language};
use implicitize::shape::Shape;
use implicitize::{Field, grid::Resolution, mesh::Mesh, model::Model, polygonize};

/// The target, in voxels of the 128 grid.
const TARGET: f32 = 1.0;

fn torus_mesh() -> &'static Mesh {
    static MESH: OnceLock<Mesh> = OnceLock::new();
    MESH.get_or_init(|| torus(2.0, 0.6, 96, 48))
}

/// The options of a fit at 128 with levels: the pyramid starts at 32 voxels so that level 0
/// fits at a quarter of the resolution (35 voxels), and from 20 initial constraints in a few
/// iterations (the pyramid's grids take the others) so that it is deliberately coarse.
fn options(max_levels: usize) -> MeshFitOptions {
    let mut fit = FitOptions::default();
    fit.initial_constraints = 20;
    fit.max_iterations = 6;
    fit.target_error = TARGET;
    fit.coarse_start_min_axis = 32;
    fit.levels.min_axis = 100;
    fit.levels.base_target_error = 4.0;
    fit.levels.max_levels = max_levels;
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(128);
    options.fit = fit;
    options
}

fn fitted() -> &'static Fitted {
    static FITTED: OnceLock<Fitted> = OnceLock::new();
    FITTED.get_or_init(|| pipeline::fit_mesh(torus_mesh(), &options(5)).unwrap())
}

fn levels() -> &'static MultiScale {
    match fitted().model.shape() {
        Shape::Levels(levels) => levels,
        _ => panic!("the torus's level 0 met a target of 1 voxel at a quarter of the resolution"),
    }
}

/// The largest distances, in voxels of the fit's grid, from the polygonized `field` to the
/// torus and back.
fn distances(field: &dyn Field) -> (f64, f64) {
    let grid = fitted().model.grid().unwrap();
    let surface = polygonize::polygonize_field(field, grid);
    assert!(!surface.triangles.is_empty());
    let there = max_vertex_distance(&surface, torus_mesh()) / grid.voxel_size;
    let back = max_vertex_distance(torus_mesh(), &surface) / grid.voxel_size;
    (there, back)
}

/// Level 0 alone lies several voxels from the torus; with the levels the polygonized surface
/// is within the target plus a voxel (the voxelization's and polygonization's steps) both
/// ways, the fit's own E (both ways, sub-voxel) and the levels' errors at the goal's surface
/// are within the target, and every level's solve states a small residual.
#[test]
fn levels_correct_a_coarse_level_0_below_the_target() {
    let report = fitted().report.levels.as_ref().expect("a report of the levels");
    assert!(report.base_max_error_voxels > 3.0, "{report:?}");
    assert!(!report.levels.is_empty());
    let last = report.levels.last().unwrap();
    assert!(last.max_error_voxels <= f64::from(TARGET), "{report:?}");
    for (k, level) in report.levels.iter().enumerate() {
        assert!(level.solve_residual < 1e-8, "level {k}: {level:?}");
        assert!(level.bytes > 0, "level {k}: {level:?}");
        assert_eq!(level.radius_voxels, report.levels[0].radius_voxels / f64::from(1 << k));
        // A level starts from what the levels below left.
        let (before, p999_before) = match k {
            0 => (report.base_max_error_voxels, report.base_p999_error_voxels),
            _ => (report.levels[k - 1].max_error_voxels, report.levels[k - 1].p999_error_voxels),
        };
        assert_eq!(
            (level.max_error_before_voxels, level.p999_error_before_voxels),
            (before, p999_before),
            "level {k}"
        );
    }
    // Each level's bytes are what it adds to the binary file.
    let total = report.base_bytes + report.levels.iter().map(|l| l.bytes).sum::<usize>();
    assert_eq!(Some(total as u64), fitted().report.model_bytes);
    assert_eq!(total, fitted().model.to_bytes().len());
    assert_eq!(fitted().model.grid().unwrap().dims.iter().max(), Some(&128));
    let (base_there, base_back) = distances(levels().base());
    assert!(base_there.max(base_back) > 2.0, "level 0: {base_there} {base_back}");
    let (there, back) = distances(&fitted().model);
    assert!(there <= 2.0 && back <= 2.0, "with levels: {there} {back}; {report:?}");
    assert!(fitted().report.max_error_voxels <= 1.5, "E {}", fitted().report.max_error_voxels);
    // The fit is judged as its levels judge themselves, and says nothing of a missed target.
    let target = fitted().report.target.expect("a target outcome");
    assert_eq!(report.stopped, LevelsStop::TargetMet, "{report:?}");
    assert!(target.met && f64::from(target.reached_voxels) == last.max_error_voxels as f32 as f64);
    assert!(pipeline::above_target(&fitted().report).is_none());
}

/// Above `max_goal_axis` the goal is voxelized at half the resolution, its voxels exactly two
/// of the grid's, and the levels reach the grid asked for through points on the mesh: the
/// report and the model speak of the 128 grid (its thickness too), whose surface points the
/// mesh's points number, and the polygonized surface is within the target plus a voxel of the torus both ways.
#[test]
fn a_goal_at_half_the_resolution_still_reaches_the_target_on_the_grid() {
    let mut options = options(5);
    options.fit.levels.max_goal_axis = 64;
    let prepared = pipeline::Prepared::new(torus_mesh(), "the torus", &options).unwrap();
    let (grid, goal) = (*prepared.grid(), *prepared.goal().grid());
    assert_eq!(grid.dims.iter().max(), Some(&128));
    assert_eq!(goal.voxel_size, 2.0 * grid.voxel_size);
    assert_eq!(goal.dims, grid.dims.map(|n| (n - 1).div_ceil(2) + 3));
    let on_mesh = prepared.goal().mesh_points().unwrap().len() as f64;
    let on_goal = prepared.goal().surface().len() as f64;
    assert!(on_mesh > 3.0 * on_goal, "{on_mesh} points on the mesh, {on_goal} on the goal");
    let goal_depth = prepared.thickness().max_depth;
    let fitted = prepared.fit(|_, _| {}).unwrap();
    assert_eq!(fitted.report.dims, grid.dims);
    // The thickness measured on the goal, reported in voxels of the grid.
    assert_eq!(fitted.report.thickness.unwrap().max_depth, 2.0 * goal_depth);
    assert_eq!(fitted.model.grid(), Some(&grid));
    let report = fitted.report.levels.as_ref().expect("a report of the levels");
    assert!(report.levels.last().unwrap().max_error_voxels <= f64::from(TARGET), "{report:?}");
    let (there, back) = distances(&fitted.model);
    assert!(there <= 2.0 && back <= 2.0, "with levels: {there} {back}; {report:?}");
}

/// A solid whose walls the coarser goal would not hold (a torus whose tube is 6.6 voxels of the
/// 128 grid across, 3.3 of the half grid, where the thickness measure refuses it) is voxelized
/// on the grid asked for, as below `max_goal_axis`, and warns of nothing there.
#[test]
fn walls_the_coarser_goal_would_thin_are_voxelized_on_the_grid_asked_for() {
    let mut options = options(5);
    options.fit.levels.max_goal_axis = 64;
    let thin = torus(2.0, 0.12, 96, 24);
    let prepared = pipeline::Prepared::new(&thin, "the thin torus", &options).unwrap();
    assert_eq!(prepared.goal().grid(), prepared.grid());
    assert!(prepared.warnings().is_empty(), "{:?}", prepared.warnings());
    // Half the tube's width, in voxels of the grid asked for.
    let depth = prepared.thickness().max_depth;
    assert!(depth > 2.5 && depth < 4.5, "{depth} voxels deep");
}

/// Values and gradients read only the centres whose supports cover the point, and equal the
/// sums over every centre up to rounding.
#[test]
fn local_evaluation_equals_the_sum_over_every_centre() {
    let levels = levels();
    let bounds = fitted().model.bounds();
    let mut points = random_points(&bounds, 0.1, 3000, 11);
    points.extend(levels.levels().iter().flat_map(|l| l.centres().iter().take(300).copied()));
    let values = levels.values(&points);
    for (&p, &v) in points.iter().zip(&values) {
        let brute = levels.value_brute_force(p);
        assert!((levels.value(p) - brute).abs() <= 1e-9 * (1.0 + brute.abs()), "{p}");
        assert!((v - brute).abs() <= 1e-6 * (1.0 + brute.abs()), "{p}: {v} {brute}");
    }
}

/// A model with levels is written as version 2 and reads back to the same values bit for bit;
/// a model without levels is still written as version 1; a version 1 file holding levels is
/// refused, naming the file.
#[test]
fn the_model_file_keeps_levels_in_version_2() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("levels.json");
    fitted().model.save(&path).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(json["version"], 2);
    assert_eq!(json["shape"]["type"], "levels");
    assert_eq!(json["shape"]["base"]["kernel"], "r2logr");
    let dims = json["grid"]["dims"].as_array().unwrap();
    assert_eq!(dims.iter().filter_map(serde_json::Value::as_u64).max(), Some(128));
    let loaded = Model::load(&path).unwrap();
    let points = random_points(&fitted().model.bounds(), 0.1, 500, 12);
    for p in points {
        assert_eq!(loaded.value(p).to_bits(), fitted().model.value(p).to_bits());
    }
    let base = dir.path().join("base.json");
    Model::from_implicit(levels().base().clone(), fitted().model.bounds(), None)
        .save(&base)
        .unwrap();
    let base_json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&base).unwrap()).unwrap();
    assert_eq!(base_json["version"], 1);
    assert!(Model::load(&base).is_ok());
    let mut old = json.clone();
    old["version"] = 1.into();
    std::fs::write(&path, serde_json::to_string(&old).unwrap()).unwrap();
    let message = Model::load(&path).unwrap_err().to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(message.contains("detail levels in a version 1 model file"), "{message}");
}

/// The fit stores its functions on lattices (level 0 and every level), so the binary file holds
/// them as integers: a fraction of the JSON's size, read back bit for bit, from the binary file
/// and from the JSON one, which keeps the lattices.
#[test]
fn the_binary_file_stores_the_lattices_compactly_and_exactly() {
    let model = &fitted().model;
    assert!(levels().base().lattice().is_some());
    assert!(levels().levels().iter().all(|l| l.lattice().is_some()));
    let bytes = model.to_bytes();
    let json = model.to_json();
    let centres =
        levels().base().len() + levels().levels().iter().map(|l| l.centres().len()).sum::<usize>();
    // Raw f32, four numbers a centre, would be 16 bytes a centre.
    assert!(bytes.len() < centres * 8, "{} bytes for {centres} centres", bytes.len());
    assert!(bytes.len() * 20 < json.len(), "{} against {}", bytes.len(), json.len());
    let dir = tempfile::tempdir().unwrap();
    let (binary, text) = (dir.path().join("levels.imp"), dir.path().join("levels.json"));
    model.save(&binary).unwrap();
    model.save(&text).unwrap();
    let points = random_points(&model.bounds(), 0.1, 500, 13);
    for path in [&binary, &text] {
        let loaded = Model::load(path).unwrap();
        for &p in &points {
            assert_eq!(loaded.value(p).to_bits(), model.value(p).to_bits(), "{}", path.display());
        }
        assert_eq!(loaded.to_bytes(), bytes, "{} written as binary", path.display());
    }
}

/// Shaders (and so the viewer) read a model with levels: the WGSL validates, each level is
/// read through the grid index of its supports, and the texture holds level 0's centres, then
/// each level's centres, cell starts and entries. The variational morph refuses it in one line
/// naming it; the blend morph and CSG read it through its values.
#[test]
fn shaders_read_levels_and_the_variational_morph_refuses_them() {
    let model = &fitted().model;
    let wgsl = shader::source(model, "torus.json", Language::Wgsl).unwrap();
    crate::tests::support::wgsl::validate(&wgsl);
    let glsl = shader::source(model, "torus.json", Language::Glsl).unwrap();
    for k in 0..levels().levels().len() {
        for source in [&wgsl, &glsl] {
            assert!(source.contains(&format!("LEVEL{k}_STARTS[cell + 1]")), "level {k}");
        }
    }
    let (_, texture) = shader::texture_source(model, "torus.json").unwrap();
    let held: usize = levels()
        .levels()
        .iter()
        .map(|l| {
            let index = l.grid_index(1 << 18); // the texture's 64^3 cells (shader.rs)
            l.centres().len() + index.starts.len() + index.entries.len()
        })
        .sum();
    let used = levels().base().len() + held;
    assert!(texture.texels.len() / 4 >= used && texture.texels.len() / 4 < used + texture.width);
    let variational = MorphOptions { method: morph::Method::Variational, ..Default::default() };
    let message = Morph::new(model, model, &variational).err().unwrap().to_string();
    assert!(message.contains("detail levels"), "{message}");
    let blend = Morph::new(model, model, &MorphOptions::default()).unwrap();
    let p = levels().levels()[0].centres()[0];
    let scaled = model.value(p) / model.shape().distance_scale();
    assert!((blend.frame(0.5).value(p) - scaled).abs() < 1e-12);
}

/// Level 0 and the first level's support are what the options ask: a quarter of the
/// resolution (the pyramid's grids keep a margin of a voxel on every side) and 4 of its voxels,
/// 16 of the full grid.
#[test]
fn level_0_fits_at_a_quarter_of_the_resolution() {
    let report = fitted().report.levels.as_ref().unwrap();
    let longest = *report.base_dims.iter().max().unwrap();
    assert!((32..=36).contains(&longest), "{:?}", report.base_dims);
    assert_eq!(report.levels[0].radius_voxels, 16.0);
}

/// A fit of the paper's loop that stalls above its target on a grid below the levels' own
/// (the triceratops at 128 voxels to a target of 1, its patience cut to three iterations) is fitted again with detail
/// levels, and the better of the two is kept: the report says how the loop stalled, and a model
/// with levels is nearer the goal than the loop left it. Without levels nothing is tried again.
#[test]
fn a_fit_that_stalls_goes_on_with_detail_levels() {
    let (mesh, _) = implicitize::mesh::read(crate::tests::support::data::triceratops()).unwrap();
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(128);
    options.fit.patience = 3;
    options.fit.target_error = 1.0;
    let fitted = pipeline::fit_mesh(&mesh, &options).unwrap();
    let stalled = fitted.report.paper_loop.expect("the loop stalls with a patience of three");
    assert!(
        matches!(stalled.termination, Termination::NoImprovement { .. } | Termination::NoCandidate),
        "{stalled:?}"
    );
    assert!(fitted.report.levels.is_some(), "kept: the fit with levels");
    assert!(fitted.report.max_error_voxels < stalled.max_error_voxels, "{stalled:?}");
    assert!(fitted.report.table("t").contains("fitted again with detail levels"));

    options.fit.levels.max_levels = 0;
    let without = pipeline::fit_mesh(&mesh, &options).unwrap();
    assert!(without.report.paper_loop.is_none() && without.report.levels.is_none());
    assert_eq!(without.report.max_error_voxels, stalled.max_error_voxels);
}

/// The triceratops at 128 voxels to a target of 1, its loop handing over at 150 constraints.
fn triceratops_handing_over_at_150() -> (Mesh, MeshFitOptions) {
    let (mesh, _) = implicitize::mesh::read(crate::tests::support::data::triceratops()).unwrap();
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(128);
    options.fit.target_error = 1.0;
    options.fit.levels.loop_constraints = 150;
    (mesh, options)
}

/// A paper's loop that reaches `loop_constraints` above its target (here 150 on the
/// triceratops at 128 voxels to a target of 1, its forecast off) hands over to detail levels:
/// the report says the loop stopped there and the fit with levels meets the target. A
/// constraint limit the caller sets is the loop's own: the loop stops at it, and nothing is
/// tried again.
#[test]
fn a_loop_past_its_constraints_hands_over_to_detail_levels() {
    let (mesh, mut options) = triceratops_handing_over_at_150();
    options.fit.levels.forecast_margin = f64::INFINITY;
    let fitted = pipeline::fit_mesh(&mesh, &options).unwrap();
    let stalled = fitted.report.paper_loop.expect("the loop hands over at 150 constraints");
    assert_eq!(stalled.termination, Termination::LoopLimit { constraints: 150 });
    assert!(fitted.report.levels.is_some(), "the fit with levels is kept");
    let target = fitted.report.target.expect("a fit of a mesh has a target outcome");
    assert!(target.met, "{target:?}");
    // The batch manifest says it: the paper's loop, then level 0, then the levels.
    let dir = tempfile::tempdir().unwrap();
    let job = batch::Job {
        input: crate::tests::support::data::triceratops().into(),
        name: "triceratops".into(),
    };
    let mut batch_options = BatchOptions::default();
    batch_options.fit = options.clone();
    let entry = job.convert(dir.path(), &batch_options);
    let stopped = entry.stopped.expect("a converted mesh says why its fit stopped");
    assert!(
        stopped.starts_with("the paper's loop: reached 150 constraints above the target")
            && stopped.contains("; level 0: ")
            && stopped.ends_with("detail levels: the target was met"),
        "{stopped}"
    );

    options.fit.max_constraints = Some(150);
    let limited = pipeline::fit_mesh(&mesh, &options).unwrap();
    assert_eq!(limited.report.termination, Termination::ConstraintLimit { limit: 150 });
    assert!(limited.report.paper_loop.is_none() && limited.report.levels.is_none());
}

/// A paper's loop whose E forecasts far more than `loop_constraints` for its target hands over
/// as soon as it may forecast (here from 90 of 150 constraints on the triceratops at 128 voxels
/// to a target of 1, where its E is several voxels), and the fit with levels meets the target
/// (its level 0, on a quarter of the grid, meets its own with fewer than 90: a forecast from
/// a smaller share would cut it short).
#[test]
fn a_loop_on_course_past_its_constraints_hands_over_at_once() {
    let (mesh, mut options) = triceratops_handing_over_at_150();
    options.fit.levels.forecast_from = 0.6;
    let fitted = pipeline::fit_mesh(&mesh, &options).unwrap();
    let first = fitted.report.paper_loop.expect("the loop hands over on its forecast");
    let Termination::LoopForecast { constraints, forecast } = first.termination else {
        panic!("{first:?}")
    };
    assert!((90..150).contains(&constraints) && forecast > 225, "{first:?}");
    let target = fitted.report.target.expect("a fit of a mesh has a target outcome");
    assert!(target.met, "{target:?}");
    assert!(
        fitted.report.table("t").contains(&format!("(on course for {forecast} constraints at ")),
        "{}",
        fitted.report.table("t")
    );
}

/// A regular tetrahedron, outward.
fn tetrahedron() -> Mesh {
    let corners = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
    Mesh {
        vertices: corners.iter().map(|&c| implicitize::DVec3::from_array(c)).collect(),
        triangles: vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
    }
}

/// A paper's loop that meets its target E while its sharp corners are rounded off farther than
/// the target plus `mesh_slack` (a tetrahedron at 128 voxels: E is measured on the voxels,
/// which round the corners too; here the slack is a quarter of a voxel) is fitted again with
/// detail levels, which fit the mesh's points: the report says how far the loop's model was,
/// and 99.9% of the mesh lies within the target of the model kept, beyond it before. With a
/// slack the loop's model is within, the loop's model is kept as it was.
#[test]
fn a_fit_whose_corners_lie_beyond_the_target_goes_on_with_detail_levels() {
    let mesh = tetrahedron();
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(128);
    options.fit.levels.mesh_slack = 5.0;
    let within = pipeline::fit_mesh(&mesh, &options).unwrap();
    assert!(within.report.paper_loop.is_none() && within.report.levels.is_none());
    let target = f64::from(options.fit.target_error);
    assert!(within.report.max_error_voxels <= options.fit.target_error);
    let before = within.report.mesh_distance.expect("measured").judged_to_model().p99_9;
    assert!(before > target, "the corners lie {before} voxels from the loop's model");

    options.fit.levels.mesh_slack = 0.25;
    let fitted = pipeline::fit_mesh(&mesh, &options).unwrap();
    let first = fitted.report.paper_loop.expect("the loop's model is replaced");
    assert!(matches!(first.termination, Termination::TargetError { .. }), "{first:?}");
    let far = first.mesh_p999_voxels.expect("the loop met its target: how far the mesh was");
    assert!(far > target + 0.25, "{far}");
    assert!(fitted.report.levels.is_some() && fitted.report.target.is_some_and(|t| t.met));
    let after = fitted.report.mesh_distance.expect("measured").judged_to_model().p99_9;
    assert!(after < target, "the mesh lies {after} voxels from the model, {before} before");
    assert!(fitted.report.table("t").contains("0.1% of the mesh's points farther than"));
}
