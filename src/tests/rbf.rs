//! Variational implicit functions: interpolation, errors, gradients, agreement with scipy, and
//! the coarse-to-fine grid evaluation of paper 5.2.

use std::path::Path;

use implicitize::rbf::{self, evaluate_on_grid, read_constraints};
use implicitize::{
    Aabb, DVec3, Field, grid::Grid, grid::Resolution, grid::Volume, rbf::Constraint,
    rbf::ConstraintKind, rbf::Implicit, rbf::Kernel,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const KERNELS: [Kernel; 3] = [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear];

/// `n` random constraints in `dim` dimensions in a box of side `size` at `offset`, values of
/// every kind. Positions are jittered lattice points, at least a quarter of the lattice spacing
/// apart, as samples of a mesh are.
fn random_constraints(dim: usize, n: usize, seed: u64, offset: f64, size: f64) -> Vec<Constraint> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let side = (2.0 * n as f64).powf(1.0 / dim as f64).ceil() as usize;
    let mut cells: Vec<usize> = (0..side.pow(dim as u32)).collect();
    for i in (1..cells.len()).rev() {
        cells.swap(i, rng.random_range(0..=i));
    }
    cells[..n]
        .iter()
        .enumerate()
        .map(|(i, &cell)| {
            let p: Vec<f64> = (0..dim)
                .map(|a| {
                    let k = (cell / side.pow(a as u32)) % side;
                    offset + size * (k as f64 + 0.25 + 0.5 * rng.random::<f64>()) / side as f64
                })
                .collect();
            let value = match i % 3 {
                0 => 0.0,
                1 => rng.random::<f64>(),
                _ => -rng.random::<f64>(),
            };
            Constraint::new(&p, value)
        })
        .collect()
}

fn flat(constraints: &[Constraint]) -> Vec<f64> {
    constraints.iter().flat_map(|c| c.position().to_vec()).collect()
}

fn max_relative_miss(implicit: &Implicit, constraints: &[Constraint], reference: f64) -> f64 {
    let values = implicit.values_flat(&flat(constraints));
    values.iter().zip(constraints).map(|(v, c)| (v - c.value()).abs()).fold(0.0, f64::max)
        / reference
}

#[test]
fn interpolation_reproduces_every_constraint_in_2d_3d_and_4d() {
    for dim in 2..=4 {
        for kernel in KERNELS {
            let constraints = random_constraints(dim, 300, dim as u64, 0.0, 1.0);
            let implicit = Implicit::solve(dim, kernel, &constraints).unwrap();
            assert_eq!((implicit.dim(), implicit.kernel(), implicit.len()), (dim, kernel, 300));
            let largest = constraints.iter().map(|c| c.value().abs()).fold(0.0, f64::max);
            let miss = max_relative_miss(&implicit, &constraints, largest);
            assert!(miss < 1e-8, "dim {dim} {kernel}: relative miss {miss:e}");
            assert!(
                implicit.residual() < 1e-8,
                "dim {dim} {kernel}: residual {:e}",
                implicit.residual()
            );
            let one_by_one =
                constraints.iter().map(|c| (implicit.value_at(c.position()) - c.value()).abs());
            assert!(one_by_one.fold(0.0, f64::max) / largest < 1e-8);
        }
    }
}

#[test]
fn far_from_the_origin_and_in_large_units_interpolation_holds() {
    // A mesh a million units from the origin in units a thousand times larger.
    let base = random_constraints(3, 400, 7, 0.0, 1.0);
    let moved: Vec<Constraint> = base
        .iter()
        .map(|c| {
            Constraint::new(
                &c.position().iter().map(|x| 1e6 + 1e3 * x).collect::<Vec<_>>(),
                c.value(),
            )
        })
        .collect();
    let a = Implicit::solve(3, Kernel::ThinPlate, &base).unwrap();
    let b = Implicit::solve(3, Kernel::ThinPlate, &moved).unwrap();
    let largest = base.iter().map(|c| c.value().abs()).fold(0.0, f64::max);
    assert!(max_relative_miss(&b, &moved, largest) < 1e-8);
    // The same function up to the move: r^2 log r is invariant up to the polynomial, which the
    // interpolation pins down.
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for _ in 0..100 {
        let p: Vec<f64> = (0..3).map(|_| rng.random::<f64>()).collect();
        let q: Vec<f64> = p.iter().map(|x| 1e6 + 1e3 * x).collect();
        let (fa, fb) = (a.value_at(&p), b.value_at(&q));
        assert!((fa - fb).abs() < 1e-8 * largest.max(fa.abs()), "{fa} vs {fb}");
    }
}

#[test]
fn all_zero_values_interpolate_to_zero_relative_to_the_extent() {
    let constraints: Vec<Constraint> = random_constraints(3, 50, 3, 10.0, 5.0)
        .iter()
        .map(|c| Constraint::new(c.position(), 0.0))
        .collect();
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    assert!(max_relative_miss(&implicit, &constraints, 5.0) < 1e-8);
    assert!(implicit.residual() < 1e-8);
    assert!(implicit.value_at(&[11.0, 12.0, 13.0]).abs() < 1e-8);
}

#[test]
fn an_affine_function_is_reproduced_everywhere() {
    // Values from an affine function are met by the polynomial alone, so f is that function
    // everywhere, not only at the constraints.
    let affine = |p: &[f64]| 0.3 - 2.0 * p[0] + 0.5 * p[1] + 1.5 * p[2];
    let constraints: Vec<Constraint> = random_constraints(3, 80, 4, -1.0, 2.0)
        .iter()
        .map(|c| Constraint::new(c.position(), affine(c.position())))
        .collect();
    for kernel in KERNELS {
        let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
        for p in [[0.0, 0.0, 0.0], [3.0, -2.0, 1.0], [0.2, 0.9, -0.7]] {
            assert!((implicit.value_at(&p) - affine(&p)).abs() < 1e-9, "{kernel} at {p:?}");
            let g = implicit.gradient_at(&p);
            assert!(
                (g[0] + 2.0).abs() < 1e-8 && (g[1] - 0.5).abs() < 1e-8 && (g[2] - 1.5).abs() < 1e-8,
                "{g:?}"
            );
        }
    }
}

#[test]
fn a_sphere_is_positive_inside_and_negative_outside() {
    let mut constraints = vec![Constraint::new(&[0.0, 0.0, 0.0], 1.0)];
    for i in 0..200 {
        // Points spread over the unit sphere (a Fibonacci lattice).
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / 200.0;
        let (r, phi) = ((1.0 - z * z).sqrt(), i as f64 * 2.399_963);
        constraints.push(Constraint::new(&[r * phi.cos(), r * phi.sin(), z], 0.0));
    }
    constraints.push(Constraint::new(&[0.0, 0.0, 2.0], -1.0));
    assert_eq!(constraints[0].kind(), ConstraintKind::Interior);
    assert_eq!(constraints[1].kind(), ConstraintKind::Boundary);
    assert_eq!(constraints[201].kind(), ConstraintKind::Exterior);
    let implicit = Implicit::solve(3, Kernel::default(), &constraints).unwrap();
    assert!(implicit.value(DVec3::new(0.3, -0.2, 0.1)) > 0.0);
    assert!(implicit.value(DVec3::new(1.4, 0.2, -0.3)) < 0.0);
    // The gradient points inside.
    let g = implicit.gradient(DVec3::new(0.0, 1.0, 0.0));
    assert!(g.y < 0.0 && g.y.abs() > 10.0 * g.x.abs().max(g.z.abs()), "{g}");
}

#[test]
fn the_analytic_gradient_matches_finite_differences() {
    for dim in 2..=4 {
        for kernel in KERNELS {
            let constraints = random_constraints(dim, 60, 10 + dim as u64, 0.0, 1.0);
            let implicit = Implicit::solve(dim, kernel, &constraints).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            for _ in 0..10 {
                let p: Vec<f64> = (0..dim).map(|_| rng.random::<f64>()).collect();
                let g = implicit.gradient_at(&p);
                assert_eq!(g.len(), dim);
                let h = 1e-6;
                for a in 0..dim {
                    let (mut lo, mut hi) = (p.clone(), p.clone());
                    lo[a] -= h;
                    hi[a] += h;
                    let fd = (implicit.value_at(&hi) - implicit.value_at(&lo)) / (2.0 * h);
                    let scale = g.iter().map(|v| v.abs()).fold(1.0, f64::max);
                    assert!(
                        (fd - g[a]).abs() < 1e-5 * scale,
                        "dim {dim} {kernel} axis {a}: {fd} vs {}",
                        g[a]
                    );
                }
            }
        }
    }
}

#[test]
fn batches_single_points_and_the_field_agree_bit_for_bit() {
    let constraints = random_constraints(3, 123, 12, 0.0, 1.0);
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let points: Vec<[f64; 3]> =
        (0..1_037).map(|_| [rng.random(), rng.random(), rng.random()]).collect();
    let batch = implicit.values3(&points);
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    assert_eq!(batch, implicit.values_flat(&flat));
    let dvec: Vec<DVec3> = points.iter().map(|&p| DVec3::from_array(p)).collect();
    assert_eq!(batch, implicit.values(&dvec));
    for i in [0, 1, 7, 8, 511, 512, 1_036] {
        assert_eq!(batch[i], implicit.value_at(&points[i]));
        assert_eq!(batch[i], implicit.value(dvec[i]));
    }
}

#[test]
fn a_2d_function_ignores_z_through_the_field() {
    let constraints = random_constraints(2, 40, 14, 0.0, 1.0);
    let implicit = Implicit::solve(2, Kernel::ThinPlate, &constraints).unwrap();
    let v = implicit.value_at(&[0.3, 0.6]);
    assert_eq!(implicit.value(DVec3::new(0.3, 0.6, 5.0)), v);
    assert_eq!(implicit.values3(&[[0.3, 0.6, -2.0]])[0], v);
    assert_eq!(implicit.gradient(DVec3::new(0.3, 0.6, 1.0)).z, 0.0);
}

fn solve_error(dim: usize, constraints: &[Constraint]) -> String {
    Implicit::solve(dim, Kernel::ThinPlate, constraints).unwrap_err().to_string()
}

#[test]
fn coincident_and_nearly_coincident_constraints_are_errors() {
    let mut constraints = random_constraints(3, 20, 15, 0.0, 1.0);
    constraints[12] = Constraint::new(constraints[4].position(), 0.5);
    let message = solve_error(3, &constraints);
    assert!(message.contains("constraints 5 and 13") && message.contains("coincide"), "{message}");
    let mut near = constraints[4].position().to_vec();
    near[1] += 1e-12;
    constraints[12] = Constraint::new(&near, 0.5);
    assert!(solve_error(3, &constraints).contains("coincide"));
}

#[test]
fn too_few_or_flat_constraints_are_errors() {
    let three =
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].map(|p| Constraint::new(&p, 0.0));
    assert!(solve_error(3, &three).contains("at least 4 affinely independent"));
    let plane: Vec<Constraint> = (0..30)
        .map(|i| Constraint::new(&[(i % 6) as f64, (i / 6) as f64, 2.0], (i % 2) as f64))
        .collect();
    assert!(solve_error(3, &plane).contains("plane"), "{}", solve_error(3, &plane));
    let line: Vec<Constraint> =
        (0..10).map(|i| Constraint::new(&[i as f64, 2.0 * i as f64], 0.0)).collect();
    assert!(solve_error(2, &line).contains("line"));
    let same: Vec<Constraint> = (0..10).map(|_| Constraint::new(&[1.0, 1.0], 0.0)).collect();
    assert!(solve_error(2, &same).contains("affinely independent"));
    assert!(solve_error(2, &[]).contains("0 constraints"));
}

/// As many constraints as polynomial terms (a tetrahedron in 3D, a triangle in 2D) are
/// interpolated by the degree-one polynomial alone, with no weight.
#[test]
fn as_many_constraints_as_terms_give_their_polynomial() {
    let corners = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 4.0]];
    let plane = |p: &[f64; 3]| 1.0 + 0.5 * p[0] - 0.25 * p[1] + 2.0 * p[2];
    let constraints = corners.map(|p| Constraint::new(&p, plane(&p)));
    for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
        let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
        for p in [[0.5, 0.5, 0.5], [-3.0, 7.0, 1.0], [10.0, -2.0, 5.0]] {
            let value = implicit.value_at(&p);
            assert!((value - plane(&p)).abs() < 1e-9, "{kernel:?} at {p:?}: {value}");
        }
    }
    let triangle = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]].map(|p| Constraint::new(&p, -2.0));
    let implicit = Implicit::solve(2, Kernel::ThinPlate, &triangle).unwrap();
    assert!((implicit.value_at(&[5.0, -3.0]) + 2.0).abs() < 1e-9);
}

#[test]
fn nan_wrong_coordinates_and_bad_dimensions_are_errors() {
    let mut constraints = random_constraints(3, 20, 16, 0.0, 1.0);
    constraints[3] = Constraint::new(&[0.1, f64::NAN, 0.2], 0.0);
    assert!(solve_error(3, &constraints).contains("constraint 4 has a NaN"));
    constraints[3] = Constraint::new(&[0.1, 0.3, 0.2], f64::INFINITY);
    assert!(solve_error(3, &constraints).contains("constraint 4 has a NaN or infinite"));
    constraints[3] = Constraint::new(&[0.1, 0.3], 0.0);
    assert!(solve_error(3, &constraints).contains("constraint 4 has 2 coordinates, expected 3"));
    assert!(solve_error(5, &constraints).contains("dimension 5"));
    assert!(solve_error(1, &constraints).contains("dimension 1"));
}

#[test]
fn kernel_names_round_trip() {
    for kernel in KERNELS {
        assert_eq!(Kernel::from_name(kernel.name()), Some(kernel));
        assert_eq!(serde_json::to_string(&kernel).unwrap(), format!("\"{}\"", kernel.name()));
    }
    assert_eq!(Kernel::default(), Kernel::ThinPlate);
    assert_eq!(Kernel::from_name("gaussian"), None);
}

/// Reads a 1D float64 .npy array.
fn read_vector(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap();
    npyz::NpyFile::new(&bytes[..]).unwrap().into_vec::<f64>().unwrap()
}

#[test]
fn bunny_values_match_scipy_rbf_interpolator() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let (dim, constraints) = read_constraints(&data.join("bunny_constraints.csv")).unwrap();
    assert_eq!((dim, constraints.len()), (3, 700));
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let (points, columns) = implicitize::npy::read_rows(&data.join("bunny_points.npy")).unwrap();
    assert_eq!(columns, 3);
    let scipy = read_vector(&data.join("bunny_scipy_values.npy"));
    let ours = implicit.values_flat(&points);
    assert_eq!(ours.len(), scipy.len());
    let reference = scipy.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let worst = ours.iter().zip(&scipy).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(
        worst <= 1e-6 * reference,
        "worst difference {worst:e} vs largest |value| {reference:e}"
    );
    // Interpolation to 1e-8 of the largest |value| (4 voxels).
    let largest = constraints.iter().map(|c| c.value().abs()).fold(0.0, f64::max);
    assert!(max_relative_miss(&implicit, &constraints, largest) < 1e-8);
}

// ---- coarse-to-fine grid evaluation (paper 5.2) ----

/// A field given by a closure, for analytic test fields.
struct Analytic<F: Fn(DVec3) -> f64 + Sync>(F);

impl<F: Fn(DVec3) -> f64 + Sync> Field for Analytic<F> {
    fn value(&self, p: DVec3) -> f64 {
        (self.0)(p)
    }
    fn gradient(&self, _: DVec3) -> DVec3 {
        unimplemented!("not needed by grid evaluation")
    }
}

fn full_evaluation<F: Field + ?Sized>(field: &F, grid: &Grid) -> Vec<f64> {
    let points: Vec<DVec3> = (0..grid.len()).map(|v| grid.position(grid.voxel(v))).collect();
    field.values(&points)
}

/// Checks every voxel's sign against a full evaluation (so every sign change between neighbours
/// that the full evaluation has is found) and the coarse samples' values; returns the number of
/// sign changes between neighbours.
fn assert_same_signs<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    goal: Option<&Volume<f32>>,
) -> usize {
    let volume = evaluate_on_grid(field, grid, goal);
    assert_eq!(volume.grid, *grid);
    let full = full_evaluation(field, grid);
    let mut changes = 0;
    for v in 0..grid.len() {
        assert_eq!(
            volume.data[v] > 0.0,
            full[v] > 0.0,
            "voxel {:?}: {} vs {}",
            grid.voxel(v),
            volume.data[v],
            full[v]
        );
        let [i, j, k] = grid.voxel(v);
        if [i, j, k].iter().all(|&c| c % 4 == 0) {
            assert_eq!(volume.data[v], full[v] as f32, "coarse sample {:?}", [i, j, k]);
        }
        for n in [[i + 1, j, k], [i, j + 1, k], [i, j, k + 1]] {
            if n[0] < grid.dims[0] && n[1] < grid.dims[1] && n[2] < grid.dims[2] {
                changes += usize::from((full[v] > 0.0) != (full[grid.index(n)] > 0.0));
            }
        }
    }
    changes
}

fn grid_around(min: f64, max: f64, n: usize) -> Grid {
    Grid::around(
        &Aabb { min: DVec3::splat(min), max: DVec3::splat(max) },
        Resolution::LongestAxis(n),
    )
    .unwrap()
}

#[test]
fn grid_evaluation_finds_every_sign_change_of_analytic_fields() {
    // Grid sizes 45 and 47 exercise both a last coarse sample on and off the 4-voxel lattice.
    for n in [45, 47] {
        let grid = grid_around(-1.0, 1.0, n);
        let sphere = Analytic(|p: DVec3| 0.8 - p.length());
        let torus = Analytic(|p: DVec3| {
            0.25 - (DVec3::new((p.x * p.x + p.y * p.y).sqrt() - 0.6, 0.0, p.z)).length()
        });
        // Blobs a few coarse cubes across, scattered.
        let blobs = Analytic(|p: DVec3| {
            let centres = [[0.5, 0.5, 0.5], [-0.6, 0.2, -0.4], [0.1, -0.7, 0.3], [-0.3, -0.3, 0.6]];
            centres
                .iter()
                .map(|c| 0.15 - (p - DVec3::from_array(*c)).length())
                .fold(f64::MIN, f64::max)
        });
        let wavy = Analytic(|p: DVec3| (5.0 * p.x).sin() * (4.0 * p.y).cos() + 0.5 * p.z);
        for field in [&sphere as &dyn Field, &torus, &blobs, &wavy] {
            let changes = assert_same_signs(field, &grid, None);
            assert!(changes > 100, "{changes} sign changes: the test field has no surface");
        }
    }
}

#[test]
fn grid_evaluation_finds_every_sign_change_of_a_fitted_model() {
    // 300 constraints: a torus's surface, with interior and exterior offsets.
    let mut constraints = Vec::new();
    for i in 0..100 {
        let (u, v) = (i as f64 * 0.6283, i as f64 * 2.3999);
        let ring = DVec3::new(u.cos(), u.sin(), 0.0);
        let normal = ring * v.cos() + DVec3::Z * v.sin();
        let p = ring * 0.6 + normal * 0.25;
        constraints.push(Constraint::new(&p.to_array(), 0.0));
        constraints.push(Constraint::new(&(p - normal * 0.05).to_array(), 0.05));
        constraints.push(Constraint::new(&(p + normal * 0.05).to_array(), -0.05));
    }
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let grid = grid_around(-1.0, 1.0, 50);
    let changes = assert_same_signs(&implicit, &grid, None);
    assert!(changes > 1000, "{changes}");
    // With the goal's signed distance, a shell around the goal boundary is always sampled.
    let goal = Volume {
        grid,
        data: (0..grid.len())
            .map(|v| {
                let p = grid.position(grid.voxel(v));
                let q = DVec3::new((p.x * p.x + p.y * p.y).sqrt() - 0.6, 0.0, p.z);
                ((0.25 - q.length()) / grid.voxel_size) as f32
            })
            .collect(),
    };
    assert_same_signs(&implicit, &grid, Some(&goal));
}

/// The documented blind spot, and how the goal shell covers it.
#[test]
fn a_component_smaller_than_a_coarse_cube_is_found_only_near_the_goal() {
    let grid = grid_around(-1.0, 1.0, 45);
    // A speck one voxel across, centred in a coarse cube: all eight corners are outside.
    let centre = grid.position([22, 22, 22]);
    let speck = Analytic(move |p: DVec3| 0.5 * grid.voxel_size - (p - centre).length());
    let full = full_evaluation(&speck, &grid);
    let inside = grid.index([22, 22, 22]);
    assert!(full[inside] > 0.0);
    let far_goal = Volume::filled(grid, -100.0f32);
    assert!(
        evaluate_on_grid(&speck, &grid, Some(&far_goal)).data[inside] < 0.0,
        "missed, as documented"
    );
    let mut near_goal = far_goal.clone();
    // A voxel of the speck's cube 8 voxels from the goal boundary: the cube is sampled finely.
    near_goal.data[grid.index([24, 22, 22])] = -8.0;
    assert_eq!(evaluate_on_grid(&speck, &grid, Some(&near_goal)).data[inside], full[inside] as f32);
}

#[test]
fn grid_evaluation_works_on_a_2d_grid() {
    let grid = Grid { dims: [37, 30, 1], origin: [-1.0, -1.0, 0.0], voxel_size: 2.0 / 36.0 };
    assert!(grid.is_2d());
    let circle = Analytic(|p: DVec3| 0.7 - (p.x * p.x + p.y * p.y).sqrt());
    assert!(assert_same_signs(&circle, &grid, None) > 50);
    let constraints: Vec<Constraint> = (0..40)
        .map(|i| {
            let t = i as f64 * std::f64::consts::TAU / 40.0;
            Constraint::new(&[0.6 * t.cos(), 0.4 * t.sin()], 0.0)
        })
        .chain([Constraint::new(&[0.0, 0.0], 1.0)])
        .collect();
    let ellipse = Implicit::solve(2, Kernel::ThinPlate, &constraints).unwrap();
    assert!(assert_same_signs(&ellipse, &grid, None) > 50);
}

#[test]
fn csv_files_name_the_file_and_line_of_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let ok = write("ok.csv", "x,y,value\n0,0,0\n1,0,0.5\n\n0,1,-1\n");
    let (dim, constraints) = read_constraints(&ok).unwrap();
    assert_eq!((dim, constraints.len()), (2, 3));
    assert_eq!(constraints[2].position(), &[0.0, 1.0]);
    let cases = [
        ("header.csv", "a,b,c\n1,2,3\n", "line 1"),
        ("fields.csv", "x,y,z,value\n1,2,3,4\n1,2,3\n", "line 3"),
        ("number.csv", "x,y,z,value\n1,2,3,4\n1,two,3,4\n", "line 3"),
        ("nan.csv", "x,y,z,value\n1,2,3,nan\n", "line 2"),
        ("empty.csv", "", "empty"),
        ("rows.csv", "x,y,z,value\n", "no rows"),
    ];
    for (name, text, want) in cases {
        let message = read_constraints(&write(name, text)).unwrap_err().to_string();
        assert!(message.contains(name) && message.contains(want), "{message}");
    }
    let points = write("points.csv", "x,y,z\n1,2,3\n4,5,6\n");
    assert_eq!(rbf::read_points(&points).unwrap(), (3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
}

/// What the fit reads from the volume near a current surface that lies near the goal is what a
/// full evaluation gives: the surface point projected from each boundary voxel, and the
/// first-order signed distance up to a voxel and a half from a boundary voxel (the goal side's
/// surface points), on the bunny's 700-constraint model at 160 voxels. (With the middle level's
/// slope margin at 1 instead of 2, one distance in a thousand is off by 0.02 to 0.7 voxels.)
#[test]
fn grid_evaluation_is_exact_where_the_fit_reads_it() {
    use implicitize::edt::{boundary_voxels, signed_distance};
    use implicitize::metrics::SubVoxel;
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let (_, constraints) = read_constraints(&data.join("bunny_constraints.csv")).unwrap();
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
    let corner = |pick: fn(DVec3, DVec3) -> DVec3, start: f64| {
        constraints
            .iter()
            .fold(DVec3::splat(start), |m, c| pick(m, DVec3::from_slice(c.position())))
    };
    let bounds =
        Aabb { min: corner(DVec3::min, f64::INFINITY), max: corner(DVec3::max, -f64::INFINITY) };
    let grid = Grid::around(&bounds, Resolution::LongestAxis(160)).unwrap();
    let values = full_evaluation(&implicit, &grid);
    let full = Volume { grid, data: values.iter().map(|&v| v as f32).collect() };
    let sd = signed_distance(&Volume { grid, data: values.iter().map(|&v| v > 0.0).collect() });
    // The goal: the surface itself, so that every cube near it is refined as near a fit's goal.
    let sampled = evaluate_on_grid(&implicit, &grid, Some(&sd));
    let [a, b] =
        [&sampled, &full].map(|values| SubVoxel { values, level: 0.0, sd: &sd, reach: 2.0 });
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let boundary = boundary_voxels(&sd);
    assert!(boundary.len() > 40_000, "{} boundary voxels", boundary.len());
    for v in boundary {
        let p = DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        let moved = (a.project(p) - b.project(p)).length();
        assert!(moved < 0.01, "{v:?}: projections {moved} voxels apart");
        let q = p + DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - DVec3::ONE;
        let off = (a.signed_distance(q) - b.signed_distance(q)).abs();
        assert!(off < 0.01, "{q}: distances {off} voxels apart");
    }
}
