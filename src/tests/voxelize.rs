//! Voxelization (paper 4.1): known solids, meshes that are open, flipped, inverted,
//! overlapping or hollow, unit independence, and bad input.

use std::collections::HashMap;

use crate::tests::support::data::triceratops;
use crate::tests::support::meshes::{merge, torus};
use implicitize::edt::inside;
use implicitize::voxelize::{VoxelizeOptions, voxelize};
use implicitize::{DVec3, grid::Grid, grid::Resolution, grid::Volume, mesh::Mesh};

/// A sphere: an icosahedron subdivided `levels` times, outward facing.
fn sphere(centre: DVec3, radius: f64, levels: usize) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, vertices: &mut Vec<DVec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
                vertices.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) =
                    (mid(a, b, &mut vertices), mid(b, c, &mut vertices), mid(c, a, &mut vertices));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    Mesh { vertices: vertices.iter().map(|&v| centre + radius * v).collect(), triangles }
}

fn inverted(m: &Mesh) -> Mesh {
    Mesh {
        vertices: m.vertices.clone(),
        triangles: m.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
    }
}

/// Drops every `drop`-th triangle and flips about 30% of the others (a fixed pattern).
fn damaged(m: &Mesh, drop: usize) -> Mesh {
    let triangles = m
        .triangles
        .iter()
        .enumerate()
        .filter(|(t, _)| t % drop != drop / 2)
        .map(|(t, &[a, b, c])| if (t * 7919) % 10 < 3 { [a, c, b] } else { [a, b, c] })
        .collect();
    Mesh { vertices: m.vertices.clone(), triangles }
}

fn grid_for(mesh: &Mesh, n: usize) -> Grid {
    Grid::around(&mesh.bounds().unwrap(), Resolution::LongestAxis(n)).unwrap()
}

fn solid(mesh: &Mesh, grid: &Grid) -> Volume<bool> {
    inside(&voxelize(mesh, grid, &VoxelizeOptions::default()).unwrap().density)
}

/// Checks `got` against an analytic signed distance (in mesh units, inside positive) at every
/// voxel more than one voxel from the surface, and returns how many voxels were checked.
fn check_against(got: &Volume<bool>, distance: impl Fn(DVec3) -> f64) -> usize {
    let g = got.grid;
    let mut checked = 0;
    for index in 0..g.len() {
        let d = distance(g.position(g.voxel(index))) / g.voxel_size;
        if d.abs() > 1.0 {
            assert_eq!(
                got.data[index],
                d > 0.0,
                "voxel {:?} at distance {d:.2} voxels",
                g.voxel(index)
            );
            checked += 1;
        }
    }
    checked
}

fn sphere_distance(centre: DVec3, radius: f64) -> impl Fn(DVec3) -> f64 {
    move |p| radius - p.distance(centre)
}

#[test]
fn a_sphere_is_solid_and_its_densities_add_up_to_its_volume() {
    let (c, r) = (DVec3::new(1.0, 2.0, 3.0), 2.0);
    let mesh = sphere(c, r, 4);
    let grid = grid_for(&mesh, 40);
    let density = voxelize(&mesh, &grid, &VoxelizeOptions::default()).unwrap().density;
    assert!(check_against(&inside(&density), sphere_distance(c, r)) > 40 * 40 * 30);
    assert!(density.data.iter().all(|&d| (0.0..=1.0).contains(&d)));
    let fractional: Vec<usize> =
        (0..grid.len()).filter(|&i| density.data[i] > 0.0 && density.data[i] < 1.0).collect();
    assert!(fractional.len() > 1000, "{} partial voxels", fractional.len());
    for &i in &fractional {
        let d = sphere_distance(c, r)(grid.position(grid.voxel(i))) / grid.voxel_size;
        assert!(
            d.abs() < 1.5,
            "partial density {} at {d:.2} voxels from the surface",
            density.data[i]
        );
    }
    // The polyhedron's volume, by the divergence theorem, in voxels.
    let exact: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum::<f64>()
        / grid.voxel_size.powi(3);
    let sum: f64 = density.data.iter().map(|&d| f64::from(d)).sum();
    assert!((sum - exact).abs() < 0.005 * exact, "densities sum to {sum}, volume {exact}");
}

#[test]
fn a_torus_keeps_its_hole() {
    let mesh = torus(3.0, 1.0, 64, 32);
    let grid = grid_for(&mesh, 48);
    let distance = |p: DVec3| 1.0 - DVec3::new(p.truncate().length() - 3.0, p.z, 0.0).length();
    // The polygonal torus lies within 0.02 of the smooth one, far less than a voxel.
    assert!(check_against(&solid(&mesh, &grid), distance) > 40 * 40 * 10);
}

#[test]
fn open_flipped_and_inverted_meshes_give_the_intact_solid() {
    let (c, r) = (DVec3::ZERO, 1.0);
    let intact = sphere(c, r, 4);
    let grid = grid_for(&intact, 40);
    let expect = solid(&intact, &grid);
    // Open (a cap of triangles removed, as the bunny's base), flipped and inverted variants.
    let open = Mesh {
        vertices: intact.vertices.clone(),
        triangles: intact
            .triangles
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&i| intact.vertices[i as usize].z > -0.85))
            .collect(),
    };
    assert!(open.triangles.len() < intact.triangles.len() - 50);
    for (name, mesh) in [
        ("open", open.clone()),
        ("open and inverted", inverted(&open)),
        ("inverted", inverted(&intact)),
        ("holes and 30% flipped", damaged(&intact, 97)),
        ("holes, 30% flipped, inverted", inverted(&damaged(&intact, 97))),
    ] {
        let got = solid(&mesh, &grid);
        // Where the cap is missing, the hole is closed across its rim: leave that band out.
        let capless = |p: DVec3| {
            if p.z < -0.75 && name.starts_with("open") { 0.0 } else { sphere_distance(c, r)(p) }
        };
        let checked = check_against(&got, capless);
        assert!(checked > 30000, "{name}");
        // Compared with the intact sphere's voxelization, away from the missing cap.
        let compared: Vec<usize> = (0..grid.len())
            .filter(|&i| !name.starts_with("open") || grid.position(grid.voxel(i)).z >= -0.75)
            .collect();
        let same = compared.iter().filter(|&&i| got.data[i] == expect.data[i]).count();
        assert!(
            same as f64 > 0.998 * compared.len() as f64,
            "{name}: {same} of {} voxels agree",
            compared.len()
        );
    }
}

#[test]
fn overlapping_parts_unite_and_inner_shells_stay_hollow() {
    let (a, b) = (DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0));
    let union = merge(&sphere(a, 1.0, 3), &sphere(b, 1.0, 3));
    let grid = grid_for(&union, 40);
    let d = |p: DVec3| sphere_distance(a, 1.0)(p).max(sphere_distance(b, 1.0)(p));
    check_against(&solid(&union, &grid), d);
    let hollow = merge(&sphere(DVec3::ZERO, 2.0, 3), &inverted(&sphere(DVec3::ZERO, 1.0, 3)));
    let grid = grid_for(&hollow, 40);
    let d =
        |p: DVec3| sphere_distance(DVec3::ZERO, 2.0)(p).min(-sphere_distance(DVec3::ZERO, 1.0)(p));
    check_against(&solid(&hollow, &grid), d);
}

#[test]
fn scaled_and_moved_meshes_give_the_same_volume_voxel_for_voxel() {
    let mesh = damaged(&torus(3.0, 1.2, 40, 24), 53);
    let far = Mesh {
        vertices: mesh.vertices.iter().map(|&p| p * 1000.0 + DVec3::new(1e5, -2e5, 3e5)).collect(),
        triangles: mesh.triangles.clone(),
    };
    let (g1, g2) = (grid_for(&mesh, 36), grid_for(&far, 36));
    assert_eq!(g1.dims, g2.dims);
    let (v1, v2) = (
        voxelize(&mesh, &g1, &VoxelizeOptions::default()).unwrap().density,
        voxelize(&far, &g2, &VoxelizeOptions::default()).unwrap().density,
    );
    assert_eq!(v1.data, v2.data);
}

#[test]
fn supersampling_one_gives_binary_densities_and_the_same_centres() {
    let mesh = sphere(DVec3::ZERO, 1.0, 3);
    let grid = grid_for(&mesh, 30);
    let binary =
        voxelize(&mesh, &grid, &VoxelizeOptions::default().with_supersampling(1)).unwrap().density;
    assert!(binary.data.iter().all(|&d| d == 0.0 || d == 1.0));
    let fine =
        voxelize(&mesh, &grid, &VoxelizeOptions::default().with_supersampling(5)).unwrap().density;
    assert!(fine.data.iter().any(|&d| d > 0.0 && d < 1.0));
    check_against(&inside(&binary), sphere_distance(DVec3::ZERO, 1.0));
    check_against(&inside(&fine), sphere_distance(DVec3::ZERO, 1.0));
}

#[test]
fn the_triceratops_with_holes_and_flipped_faces_keeps_its_solid() {
    let (mesh, _) = implicitize::mesh::read(triceratops()).unwrap();
    let grid = grid_for(&mesh, 96);
    let intact = solid(&mesh, &grid);
    let sd = implicitize::edt::signed_distance(&intact);
    let broken = solid(&damaged(&mesh, 701), &grid);
    let far: Vec<usize> = (0..grid.len()).filter(|&i| sd.data[i].abs() > 1.0).collect();
    assert!(far.len() > grid.len() / 2);
    let differ = far.iter().filter(|&&i| intact.data[i] != broken.data[i]).count();
    assert_eq!(differ, 0, "{differ} voxels more than a voxel from the surface differ");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let good = sphere(DVec3::ZERO, 1.0, 1);
    let grid = grid_for(&good, 16);
    let run =
        |m: &Mesh, o: VoxelizeOptions| voxelize(m, &grid, &o).map(|_| ()).unwrap_err().to_string();
    let o = VoxelizeOptions::default();
    assert!(run(&Mesh::default(), o).contains("no triangles"));
    let mut nan = good.clone();
    nan.vertices[3].y = f64::NAN;
    assert!(run(&nan, o).contains("vertex 3"));
    let mut bad = good.clone();
    bad.triangles[5][1] = 10_000;
    assert!(run(&bad, o).contains("triangle 5"));
    assert!(run(&good, VoxelizeOptions::default().with_supersampling(4)).contains("supersampling"));
    assert!(run(&good, VoxelizeOptions::default().with_supersampling(0)).contains("supersampling"));
    let empty = Grid { dims: [0, 4, 4], ..grid };
    assert!(voxelize(&good, &empty, &o).is_err());
}

#[test]
fn surface_points_of_a_voxelized_sphere_lie_on_it() {
    use implicitize::edt::{boundary_voxels, signed_distance, surface_point};
    let (c, r) = (DVec3::new(-4.0, 7.0, 1.0), 3.0);
    let mesh = sphere(c, r, 5);
    let grid = grid_for(&mesh, 48);
    let density = voxelize(&mesh, &grid, &VoxelizeOptions::default()).unwrap().density;
    let boundary = boundary_voxels(&signed_distance(&inside(&density)));
    assert!(boundary.len() > 2000);
    let errors: Vec<f64> = boundary
        .iter()
        .map(|&v| {
            (grid.to_world(surface_point(&density, v)).distance(c) - r).abs() / grid.voxel_size
        })
        .collect();
    let centres: Vec<f64> = boundary
        .iter()
        .map(|&v| (grid.position(v).distance(c) - r).abs() / grid.voxel_size)
        .collect();
    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len() as f64;
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    assert!(mean(&errors) < 0.06 && worst < 0.3, "mean {} max {worst} voxels", mean(&errors));
    assert!(mean(&errors) < 0.5 * mean(&centres));
}
