//! Polygonization: closed, consistently oriented meshes on the true surface of analytic
//! shapes, watertight on random volumes, open only where the grid cuts the surface.

use std::collections::HashMap;

use crate::tests::support::data::bunny;
use crate::tests::support::topology::{components, euler_characteristic};
use implicitize::polygonize::polygonize_field_dense;
use implicitize::{
    DVec3, Field, grid::Grid, grid::Resolution, grid::Volume, mesh::Mesh, polygonize::polygonize,
    polygonize::polygonize_field,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A sphere as a quadratic (not a distance): r² - |p - c|², positive inside.
struct Sphere {
    center: DVec3,
    radius: f64,
}

impl Sphere {
    fn distance(&self, p: DVec3) -> f64 {
        ((p - self.center).length() - self.radius).abs()
    }
    fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }
}

impl Field for Sphere {
    fn value(&self, p: DVec3) -> f64 {
        self.radius * self.radius - (p - self.center).length_squared()
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        -2.0 * (p - self.center)
    }
}

/// A torus around the z axis through `center` as a quartic-like implicit (not a distance):
/// r² - ((ρ - R)² + z²), positive inside.
struct Torus {
    center: DVec3,
    major: f64,
    minor: f64,
}

impl Torus {
    fn tube(&self, p: DVec3) -> (f64, f64) {
        let q = p - self.center;
        ((q.x * q.x + q.y * q.y).sqrt() - self.major, q.z)
    }
    fn distance(&self, p: DVec3) -> f64 {
        let (a, z) = self.tube(p);
        ((a * a + z * z).sqrt() - self.minor).abs()
    }
    fn volume(&self) -> f64 {
        2.0 * std::f64::consts::PI.powi(2) * self.major * self.minor * self.minor
    }
}

impl Field for Torus {
    fn value(&self, p: DVec3) -> f64 {
        let (a, z) = self.tube(p);
        self.minor * self.minor - (a * a + z * z)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let q = p - self.center;
        let rho = (q.x * q.x + q.y * q.y).sqrt().max(1e-300);
        let (a, z) = self.tube(p);
        -2.0 * DVec3::new(a * q.x / rho, a * q.y / rho, z)
    }
}

/// A field with the given surface points, so that [`polygonize_field`] follows its surface.
struct Seeded<F> {
    field: F,
    points: Vec<DVec3>,
}

impl<F: Field> Field for Seeded<F> {
    fn value(&self, p: DVec3) -> f64 {
        self.field.value(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.field.gradient(p)
    }
    fn surface_points(&self) -> Vec<DVec3> {
        self.points.clone()
    }
}

/// The union (largest value) of some spheres.
struct Spheres(Vec<Sphere>);

impl Field for Spheres {
    fn value(&self, p: DVec3) -> f64 {
        self.0.iter().map(|s| s.value(p)).fold(f64::MIN, f64::max)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let nearest = self.0.iter().max_by(|a, b| a.value(p).total_cmp(&b.value(p)));
        nearest.map_or(DVec3::ZERO, |s| s.gradient(p))
    }
}

/// A grid far from the origin in odd units, so nothing relies on unit voxels at the origin.
fn grid(dims: [usize; 3]) -> Grid {
    Grid { dims, origin: [103.5, -47.25, 6.125], voxel_size: 0.37 }
}

/// The grid's centre in mesh units.
fn centre(g: &Grid) -> DVec3 {
    g.to_world(DVec3::new(
        (g.dims[0] - 1) as f64 / 2.0,
        (g.dims[1] - 1) as f64 / 2.0,
        (g.dims[2] - 1) as f64 / 2.0,
    ))
}

/// `f` sampled at every voxel as an f32 volume.
fn sampled(g: Grid, f: impl Fn(DVec3) -> f64) -> Volume<f32> {
    let data = (0..g.len()).map(|n| f(g.position(g.voxel(n))) as f32).collect();
    Volume { grid: g, data }
}

/// Directed edges used by the mesh's triangles, with how many times each is used.
fn directed_edges(mesh: &Mesh) -> HashMap<(u32, u32), usize> {
    let mut edges = HashMap::new();
    for &[a, b, c] in &mesh.triangles {
        for e in [(a, b), (b, c), (c, a)] {
            *edges.entry(e).or_insert(0) += 1;
        }
    }
    edges
}

/// Directed edges with no reverse partner: the mesh's boundary. Fails if an edge is used twice
/// in the same direction (inconsistent orientation or a non-manifold edge).
fn boundary_edges(mesh: &Mesh) -> Vec<(u32, u32)> {
    let edges = directed_edges(mesh);
    for (e, &n) in &edges {
        assert_eq!(n, 1, "edge {e:?} is used {n} times in the same direction");
    }
    edges.keys().filter(|&&(a, b)| !edges.contains_key(&(b, a))).copied().collect()
}

/// Every edge is shared by exactly two triangles, in opposite directions.
fn assert_closed(mesh: &Mesh) {
    let open = boundary_edges(mesh);
    assert!(
        open.is_empty(),
        "{} boundary edges, e.g. {:?}",
        open.len(),
        &open[..open.len().min(3)]
    );
}

/// Every triangle has three distinct corners and an area above a tiny fraction of a voxel's
/// face; every vertex is used and none is repeated.
fn assert_well_formed(mesh: &Mesh, voxel: f64) {
    let mut used = vec![false; mesh.vertices.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        assert!(tri[0] != tri[1] && tri[1] != tri[2] && tri[2] != tri[0], "triangle {t}: {tri:?}");
        let [a, b, c] = mesh.corners(t);
        let area = 0.5 * (b - a).cross(c - a).length();
        assert!(area > 1e-8 * voxel * voxel, "triangle {t} has area {area}");
        for &v in tri {
            used[v as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "some vertex is used by no triangle");
    let mut keys: Vec<[u64; 3]> =
        mesh.vertices.iter().map(|p| p.to_array().map(f64::to_bits)).collect();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), mesh.vertices.len(), "some vertex position is repeated");
}

/// The signed volume enclosed by the mesh (positive when oriented outward).
fn signed_volume(mesh: &Mesh) -> f64 {
    let o = mesh.vertices.first().copied().unwrap_or_default();
    (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.corners(t).map(|p| p - o);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The largest distance from a vertex to the true surface, in voxels.
fn max_error(mesh: &Mesh, voxel: f64, distance: impl Fn(DVec3) -> f64) -> f64 {
    mesh.vertices.iter().map(|&p| distance(p)).fold(0.0, f64::max) / voxel
}

/// Checks everything a closed surface must satisfy and returns its vertex error in voxels.
fn check_closed_shape(
    mesh: &Mesh,
    g: &Grid,
    distance: impl Fn(DVec3) -> f64,
    volume: f64,
    volume_tolerance: f64,
    euler: i64,
) -> f64 {
    assert!(mesh.triangles.len() > 100, "{} triangles", mesh.triangles.len());
    assert_well_formed(mesh, g.voxel_size);
    assert_closed(mesh);
    assert_eq!(euler_characteristic(mesh), euler);
    assert_eq!(components(mesh), 1);
    let v = signed_volume(mesh);
    assert!(v > 0.0, "signed volume {v} is not positive: normals point inward");
    assert!((v / volume - 1.0).abs() < volume_tolerance, "volume {v} vs analytic {volume}");
    max_error(mesh, g.voxel_size, distance)
}

fn sphere_in(g: &Grid) -> Sphere {
    Sphere { center: centre(g) + DVec3::new(0.13, -0.21, 0.07), radius: 10.3 * g.voxel_size }
}

fn torus_in(g: &Grid) -> Torus {
    Torus {
        center: centre(g) + DVec3::new(0.05, 0.11, -0.03),
        major: 12.4 * g.voxel_size,
        minor: 5.2 * g.voxel_size,
    }
}

#[test]
fn a_sphere_field_polygonizes_onto_its_surface() {
    let g = grid([28, 27, 26]);
    let s = sphere_in(&g);
    let mesh = polygonize_field(&s, &g);
    let error = check_closed_shape(&mesh, &g, |p| s.distance(p), s.volume(), 0.01, 2);
    // Refined onto the zero: far tighter than the tenth of a voxel required of volumes.
    assert!(error < 0.005, "vertex {error} voxels from the sphere");
}

#[test]
fn a_torus_field_polygonizes_onto_its_surface() {
    let g = grid([40, 41, 18]);
    let t = torus_in(&g);
    let mesh = polygonize_field(&t, &g);
    let error = check_closed_shape(&mesh, &g, |p| t.distance(p), t.volume(), 0.01, 0);
    assert!(error < 0.005, "vertex {error} voxels from the torus");
}

#[test]
fn a_sphere_volume_polygonizes_within_a_tenth_of_a_voxel() {
    let g = grid([28, 27, 26]);
    let s = sphere_in(&g);
    let mesh = polygonize(&sampled(g, |p| s.value(p)), 0.0);
    let error = check_closed_shape(&mesh, &g, |p| s.distance(p), s.volume(), 0.02, 2);
    assert!(error < 0.1, "vertex {error} voxels from the sphere");
}

#[test]
fn a_torus_volume_polygonizes_within_a_tenth_of_a_voxel() {
    let g = grid([40, 41, 18]);
    let t = torus_in(&g);
    let mesh = polygonize(&sampled(g, |p| t.value(p)), 0.0);
    let error = check_closed_shape(&mesh, &g, |p| t.distance(p), t.volume(), 0.02, 0);
    assert!(error < 0.1, "vertex {error} voxels from the torus");
}

#[test]
fn a_signed_distance_volume_polygonizes_at_any_iso_level() {
    let g = grid([28, 27, 26]);
    let s = sphere_in(&g);
    // Signed distance in voxels, inside positive; the level 2.5 is a sphere 2.5 voxels smaller.
    let sd = sampled(g, |p| (s.radius - (p - s.center).length()) / g.voxel_size);
    let shrunk = Sphere { center: s.center, radius: s.radius - 2.5 * g.voxel_size };
    let mesh = polygonize(&sd, 2.5);
    let error = check_closed_shape(&mesh, &g, |p| shrunk.distance(p), shrunk.volume(), 0.02, 2);
    assert!(error < 0.1, "vertex {error} voxels from the sphere");
}

#[test]
fn random_volumes_with_outside_borders_are_watertight() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for round in 0..16 {
        // Rows of k span several 64-bit words in the later rounds.
        let long = if round < 8 { 20 } else { 140 };
        let dims = [rng.random_range(2..16), rng.random_range(2..16), rng.random_range(2..long)];
        let g = grid(dims);
        let mut volume = Volume::filled(g, -1.0f32);
        // Coarse values (some exactly at the level) in odd rounds, continuous ones in even.
        let iso = if round % 2 == 0 { 0.3 } else { 0.0 };
        for n in 0..g.len() {
            let [i, j, k] = g.voxel(n);
            let border = [i, j, k].iter().zip(dims).any(|(&c, d)| c == 0 || c + 1 == d);
            if !border {
                volume.data[n] = if round % 2 == 0 {
                    rng.random_range(-1.0..1.0)
                } else {
                    rng.random_range(-1i32..=1) as f32
                };
            }
        }
        let mesh = polygonize(&volume, iso);
        assert_well_formed(&mesh, g.voxel_size);
        assert_closed(&mesh);
        if !mesh.triangles.is_empty() {
            let v = signed_volume(&mesh);
            assert!(v > 0.0, "round {round}: signed volume {v}");
        }
    }
}

#[test]
fn values_at_the_level_count_as_inside() {
    // One voxel exactly at the level in an outside volume: a tiny closed surface around it.
    let g = grid([5, 5, 5]);
    let mut volume = Volume::filled(g, -1.0f32);
    volume.data[g.index([2, 2, 2])] = 0.0;
    let mesh = polygonize(&volume, 0.0);
    assert!(!mesh.triangles.is_empty());
    assert_well_formed(&mesh, g.voxel_size);
    assert_closed(&mesh);
    assert_eq!(euler_characteristic(&mesh), 2);
    assert!(signed_volume(&mesh) > 0.0);
    // Every vertex hugs the voxel centre.
    let error = max_error(&mesh, g.voxel_size, |p| (p - g.position([2, 2, 2])).length());
    assert!(error < 0.002, "{error}");
}

#[test]
fn a_surface_cut_by_the_grid_is_open_only_at_the_grid_bounds() {
    let g = grid([20, 18, 16]);
    // A sphere centred on the grid's corner voxel, so the grid holds an eighth of it.
    let s = Sphere { center: g.position([0, 0, 0]), radius: 9.3 * g.voxel_size };
    let mesh = polygonize_field(&s, &g);
    assert_well_formed(&mesh, g.voxel_size);
    let open = boundary_edges(&mesh);
    assert!(!open.is_empty());
    let on_bounds = |v: u32| {
        let q = g.to_grid(mesh.vertices[v as usize]);
        [q.x, q.y, q.z]
            .iter()
            .zip(g.dims)
            .any(|(&c, d)| c.abs() < 1e-9 || (c - (d - 1) as f64).abs() < 1e-9)
    };
    for (a, b) in open {
        assert!(on_bounds(a) && on_bounds(b), "boundary edge ({a}, {b}) inside the grid");
    }
    assert!(max_error(&mesh, g.voxel_size, |p| s.distance(p)) < 0.005);
}

#[test]
fn a_two_voxel_thin_plate_is_closed() {
    let g = grid([12, 30, 30]);
    let c = centre(&g);
    let h = g.voxel_size;
    // A box 2 x 20 x 20 voxels as a signed distance (inside positive).
    let half = DVec3::new(1.0, 10.0, 10.0) * h;
    let plate = sampled(g, |p| {
        let q = (p - c).abs() - half;
        -(q.max(DVec3::ZERO).length() + q.max_element().min(0.0))
    });
    let mesh = polygonize(&plate, 0.0);
    assert_well_formed(&mesh, h);
    assert_closed(&mesh);
    assert_eq!(euler_characteristic(&mesh), 2);
    assert_eq!(components(&mesh), 1);
    let v = signed_volume(&mesh) / h.powi(3);
    // Interpolation chamfers the box's edges a little.
    assert!(v > 0.0 && (v / 800.0 - 1.0).abs() < 0.05, "volume {v} voxels vs 800");
    // Faces of the plate are flat, so their vertices are exact.
    let on_face =
        mesh.vertices.iter().filter(|p| ((**p - c).x.abs() / h - 1.0).abs() < 1e-4).count();
    assert!(on_face > mesh.vertices.len() / 2);
}

#[test]
fn several_components_stay_apart() {
    let g = grid([40, 20, 20]);
    let h = g.voxel_size;
    let spheres: Vec<Sphere> = (0..3)
        .map(|n| Sphere {
            center: g.position([7 + 12 * n, 10, 10]) + DVec3::splat(0.1 * h),
            radius: 5.2 * h,
        })
        .collect();
    let union = sampled(g, |p| spheres.iter().map(|s| s.value(p)).fold(f64::MIN, f64::max));
    let mesh = polygonize(&union, 0.0);
    assert_well_formed(&mesh, h);
    assert_closed(&mesh);
    assert_eq!(components(&mesh), 3);
    assert_eq!(euler_characteristic(&mesh), 6);
    let total: f64 = spheres.iter().map(Sphere::volume).sum();
    let v = signed_volume(&mesh);
    assert!((v / total - 1.0).abs() < 0.04, "volume {v} vs analytic {total}");
}

#[test]
fn grids_without_cubes_give_empty_meshes() {
    for dims in [[10, 10, 1], [1, 10, 10], [10, 1, 10]] {
        let g = grid(dims);
        let mesh = polygonize(&Volume::filled(g, 1.0f32), 0.0);
        assert!(mesh.triangles.is_empty() && mesh.vertices.is_empty());
        let s = Sphere { center: centre(&g), radius: 3.0 * g.voxel_size };
        assert!(polygonize_field(&s, &g).triangles.is_empty());
        let seeded = Seeded { points: vec![s.center + DVec3::X * s.radius], field: s };
        assert!(polygonize_field(&seeded, &g).triangles.is_empty());
    }
}

#[test]
fn volumes_entirely_inside_or_outside_give_empty_meshes() {
    let g = grid([9, 8, 7]);
    for value in [-1.0f32, 0.0, 2.0, f32::NAN] {
        assert!(polygonize(&Volume::filled(g, value), 0.0).triangles.is_empty());
    }
}

#[test]
fn the_mesh_does_not_depend_on_the_number_of_threads() {
    // Slabs follow the thread count; the stitched mesh must come out the same, vertex for
    // vertex, and closed across every slab boundary.
    let g = grid([41, 40, 70]);
    let t = torus_in(&g);
    let volume = sampled(g, |p| t.value(p));
    let points = vec![t.center + DVec3::X * (t.major + t.minor)];
    let seeded = Seeded { points, field: torus_in(&g) };
    let with_threads = |n: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("a thread pool");
        pool.install(|| {
            (polygonize(&volume, 0.0), polygonize_field(&t, &g), polygonize_field(&seeded, &g))
        })
    };
    let one = with_threads(1);
    assert_eq!(one.2, one.1, "surface following differs from the dense path");
    for n in [2, 3, 7] {
        let many = with_threads(n);
        assert_closed(&many.0);
        assert_closed(&many.1);
        assert_closed(&many.2);
        assert!(one == many, "{n} threads give a different mesh than one");
    }
}

// ---- surface following ----

#[test]
fn surface_following_gives_the_dense_mesh_of_a_fitted_bunny() {
    let (implicit, bounds) = bunny();
    let seeds = implicit.surface_points();
    let boundary = implicit.constraints().iter().filter(|c| c.value() == 0.0).count();
    assert!(boundary > 100 && seeds.len() == boundary, "{} of {boundary}", seeds.len());
    for resolution in [40, 97] {
        let g = Grid::around(&bounds, Resolution::LongestAxis(resolution)).unwrap();
        let dense = polygonize_field_dense(&implicit, &g);
        let followed = polygonize_field(&implicit, &g);
        assert!(followed.triangles.len() > 1000, "{} triangles", followed.triangles.len());
        // Same vertices and triangles in the same order: the same mesh, bit for bit.
        assert!(followed == dense, "at {resolution}: the meshes differ");
        assert_well_formed(&followed, g.voxel_size);
        assert_closed(&followed);
        assert!(signed_volume(&followed) > 0.0);
    }
}

/// A sphere of radius 4.3 voxels centred between the coarse lattice's nodes (every 8th voxel)
/// around `cell`, so that no lattice node is inside it and no lattice edge crosses it.
fn between_nodes(g: &Grid, cell: [usize; 3]) -> Sphere {
    let centre = cell.map(|c| 8 * c + 4);
    Sphere { center: g.position(centre) + DVec3::splat(0.013), radius: 4.3 * g.voxel_size }
}

#[test]
fn two_seeded_components_between_the_lattice_nodes_are_both_found() {
    let g = grid([36, 26, 30]);
    let spheres = Spheres(vec![between_nodes(&g, [1, 1, 1]), between_nodes(&g, [3, 1, 2])]);
    let on_surface = |s: &Sphere| s.center + DVec3::new(0.0, 0.0, s.radius);
    // Points off the grid or not finite are ignored.
    let extra = [g.position([1000, 0, 0]), DVec3::NAN, DVec3::splat(f64::INFINITY)];
    let points = spheres.0.iter().map(on_surface).chain(extra).collect();
    let seeded = Seeded { points, field: spheres };
    let dense = polygonize_field_dense(&seeded, &g);
    let followed = polygonize_field(&seeded, &g);
    assert_eq!(components(&dense), 2);
    assert!(followed == dense, "the meshes differ");
    assert_closed(&followed);
    assert_eq!(euler_characteristic(&followed), 4);
    assert!(signed_volume(&followed) > 0.0);
}

#[test]
fn a_component_without_a_surface_point_is_found_only_through_the_lattice() {
    let g = grid([48, 42, 32]);
    let seeded = between_nodes(&g, [1, 1, 1]);
    let unseen = between_nodes(&g, [4, 3, 2]);
    // Large enough to hold lattice nodes, so the lattice's sign changes find it.
    let large = Sphere { center: g.position([12, 30, 20]), radius: 8.6 * g.voxel_size };
    let point = seeded.center - DVec3::X * seeded.radius;
    let all = Seeded { points: vec![point], field: Spheres(vec![seeded, unseen, large]) };
    assert_eq!(components(&polygonize_field_dense(&all, &g)), 3);
    let followed = polygonize_field(&all, &g);
    assert_eq!(components(&followed), 2);
    assert_closed(&followed);
    // The spheres are far enough apart that near the other two the unseen one never has the
    // largest value, so there the field is the same without it, and so is the mesh.
    let Spheres(mut spheres) = all.field;
    spheres.remove(1);
    assert!(followed == polygonize_field_dense(&Spheres(spheres), &g));
}

#[test]
fn surface_following_leaves_a_surface_open_only_at_the_grid_bounds() {
    let g = grid([20, 18, 16]);
    let s = Sphere { center: g.position([0, 0, 0]), radius: 9.3 * g.voxel_size };
    let points = vec![s.center + DVec3::Y * s.radius];
    let seeded = Seeded { points, field: s };
    let followed = polygonize_field(&seeded, &g);
    assert!(!boundary_edges(&followed).is_empty());
    assert!(followed == polygonize_field_dense(&seeded, &g));
}
