//! Signed distance (paper 4.2): exact against brute force and known shapes, boundary voxels,
//! surface points, interpolation and gradients.

use implicitize::edt::{
    boundary_voxels, gradient, inside, sample, signed_distance, signed_distance_within,
    surface_point,
};
use implicitize::{DVec3, grid::Grid, grid::Volume};
use proptest::prelude::*;

fn grid(dims: [usize; 3]) -> Grid {
    Grid { dims, origin: [0.0; 3], voxel_size: 1.0 }
}

/// The scipy convention by brute force: distance to the nearest voxel of the other state.
fn brute_force(v: &Volume<bool>) -> Vec<f32> {
    let g = v.grid;
    (0..g.len())
        .map(|a| {
            let pa = g.voxel(a);
            let d2 = (0..g.len())
                .filter(|&b| v.data[b] != v.data[a])
                .map(|b| {
                    let pb = g.voxel(b);
                    (0..3).map(|k| (pa[k] as f64 - pb[k] as f64).powi(2)).sum::<f64>()
                })
                .fold(f64::INFINITY, f64::min);
            let r = d2.sqrt() - 0.5;
            if v.data[a] { r as f32 } else { -r as f32 }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn equals_brute_force_on_random_volumes(
        nx in 1usize..9, ny in 1usize..9, nz in 1usize..9,
        fill in 0.05f64..0.95, seed in any::<u64>(),
    ) {
        let g = grid([nx, ny, nz]);
        let mut state = seed | 1;
        let data = (0..g.len()).map(|_| {
            state ^= state << 13; state ^= state >> 7; state ^= state << 17;
            (state % 1000) as f64 / 1000.0 < fill
        }).collect();
        let v = Volume { grid: g, data };
        prop_assert_eq!(signed_distance(&v).data, brute_force(&v));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]
    /// Within the band, the exact values; beyond it `band - 1/2` with the sign, below the true
    /// size. A few balls in a larger grid, so that lines cross the band, miss it and lie in it.
    #[test]
    fn the_banded_transform_is_exact_within_its_band(
        nx in 1usize..24, ny in 1usize..24, nz in 1usize..24,
        balls in proptest::collection::vec((0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.5f64..5.0), 0..4),
        band in 1.0f32..8.0,
    ) {
        let g = grid([nx, ny, nz]);
        let data = (0..g.len()).map(|i| {
            let p = g.voxel(i);
            balls.iter().any(|&(x, y, z, r)| {
                let c = [x * nx as f64, y * ny as f64, z * nz as f64];
                (0..3).map(|a| (p[a] as f64 - c[a]).powi(2)).sum::<f64>() <= r * r
            })
        }).collect();
        let v = Volume { grid: g, data };
        let exact = brute_force(&v);
        let banded = signed_distance_within(&v, band).data;
        for (i, (&e, &b)) in exact.iter().zip(&banded).enumerate() {
            if e.abs() < band - 0.5 {
                prop_assert_eq!(b, e, "voxel {:?}", g.voxel(i));
            } else {
                prop_assert_eq!(b, (band - 0.5).copysign(e), "voxel {:?}, exact {}", g.voxel(i), e);
            }
        }
    }
}

#[test]
fn two_dimensional_and_thin_volumes_equal_brute_force() {
    // [5, 40, 60] and [3, 1, 2000]: slabs of more than 1024 voxels, split between threads by
    // the first pass.
    for dims in
        [[23, 17, 1], [1, 30, 1], [1, 1, 40], [12, 1, 9], [1, 13, 11], [5, 40, 60], [3, 1, 2000]]
    {
        let g = grid(dims);
        let data = (0..g.len()).map(|i| (i * 2654435761usize) % 7 < 3).collect();
        let v = Volume { grid: g, data };
        assert_eq!(signed_distance(&v).data, brute_force(&v), "{dims:?}");
    }
}

#[test]
fn a_box_has_its_exact_distances() {
    let g = grid([20, 24, 18]);
    let (lo, hi) = ([5, 6, 4], [12, 17, 13]);
    let is_in = |v: [usize; 3]| (0..3).all(|a| v[a] >= lo[a] && v[a] <= hi[a]);
    let v = Volume { grid: g, data: (0..g.len()).map(|i| is_in(g.voxel(i))).collect() };
    let sd = signed_distance(&v);
    for i in 0..g.len() {
        let p = g.voxel(i);
        let expect = if is_in(p) {
            // The nearest outside voxel is straight out through the nearest face.
            (0..3).map(|a| (p[a] - lo[a] + 1).min(hi[a] + 1 - p[a])).min().unwrap() as f64 - 0.5
        } else {
            let gap =
                |a: usize| (lo[a] as f64 - p[a] as f64).max(p[a] as f64 - hi[a] as f64).max(0.0);
            -((gap(0).powi(2) + gap(1).powi(2) + gap(2).powi(2)).sqrt() - 0.5)
        };
        assert_eq!(sd.data[i], expect as f32, "{p:?}");
    }
}

#[test]
fn a_ball_is_within_a_voxel_of_its_true_distance() {
    let g = grid([41, 41, 41]);
    let (c, r) = (DVec3::splat(20.0), 14.3);
    let v = Volume {
        grid: g,
        data: (0..g.len()).map(|i| g.position(g.voxel(i)).distance(c) < r).collect(),
    };
    let sd = signed_distance(&v);
    for i in 0..g.len() {
        let truth = r - g.position(g.voxel(i)).distance(c);
        assert!(
            (f64::from(sd.data[i]) - truth).abs() < 1.0,
            "{:?}: {} vs {truth}",
            g.voxel(i),
            sd.data[i]
        );
    }
}

#[test]
fn uniform_volumes_are_infinitely_far_from_a_surface() {
    for state in [true, false] {
        let v = Volume::filled(grid([4, 5, 6]), state);
        let sd = signed_distance(&v);
        let expect = if state { f32::INFINITY } else { f32::NEG_INFINITY };
        assert!(sd.data.iter().all(|&d| d == expect));
    }
}

#[test]
fn boundary_voxels_are_inside_voxels_with_an_outside_neighbour() {
    let g = grid([15, 13, 11]);
    let data = (0..g.len()).map(|i| (i * 40503) % 11 < 6).collect();
    let v = Volume { grid: g, data };
    let boundary = boundary_voxels(&signed_distance(&v));
    let expect: Vec<[usize; 3]> = (0..g.len())
        .map(|i| g.voxel(i))
        .filter(|&p| {
            *v.get(p)
                && (0..3).any(|a| {
                    [-1isize, 1].iter().any(|&s| {
                        let x = p[a] as isize + s;
                        (0..g.dims[a] as isize).contains(&x) && {
                            let mut q = p;
                            q[a] = x as usize;
                            !*v.get(q)
                        }
                    })
                })
        })
        .collect();
    assert!(!expect.is_empty());
    assert_eq!(boundary, expect);
}

#[test]
fn inside_is_density_above_one_half() {
    let v = Volume { grid: grid([5, 1, 1]), data: vec![0.0, 0.5, 0.51, 1.0, 0.2] };
    assert_eq!(inside(&v).data, vec![false, false, true, true, false]);
}

/// Box-filtered densities of the half space x < x0 along x.
fn slab_density(x0: f64, dims: [usize; 3]) -> Volume<f32> {
    let g = grid(dims);
    let data =
        (0..g.len()).map(|i| (x0 - (g.voxel(i)[0] as f64 - 0.5)).clamp(0.0, 1.0) as f32).collect();
    Volume { grid: g, data }
}

#[test]
fn surface_points_follow_the_densities() {
    for x0 in [6.2, 6.5, 6.9, 7.3] {
        let d = slab_density(x0, [14, 5, 6]);
        let sd = signed_distance(&inside(&d));
        for voxel in boundary_voxels(&sd) {
            let p = surface_point(&d, voxel);
            assert!((p.x - x0).abs() < 1e-6, "x0 {x0}: {p:?}");
            assert_eq!([p.y, p.z], [voxel[1] as f64, voxel[2] as f64]);
        }
    }
    // A voxel with no neighbour across 1/2 steps along the gradient, at most one voxel.
    let d = slab_density(6.2, [14, 5, 6]);
    let p = surface_point(&d, [2, 2, 2]);
    assert_eq!(p, DVec3::new(2.0, 2.0, 2.0), "flat density: the centre");
    let p = surface_point(&d, [5, 2, 2]);
    assert!((p.x - 6.0).abs() < 1e-9, "{p:?}");
}

#[test]
fn sampling_is_trilinear_and_clamped_and_the_gradient_points_inward() {
    let g = grid([6, 7, 5]);
    // A linear field is reproduced exactly by trilinear interpolation.
    let f = |p: DVec3| 0.5 * p.x - 2.0 * p.y + 0.25 * p.z + 1.0;
    let v =
        Volume { grid: g, data: (0..g.len()).map(|i| f(g.position(g.voxel(i))) as f32).collect() };
    for p in [DVec3::new(1.3, 2.7, 3.1), DVec3::new(0.0, 6.0, 4.0), DVec3::new(4.99, 0.01, 2.5)] {
        assert!((f64::from(sample(&v, p)) - f(p)).abs() < 1e-5);
        assert!((gradient(&v, p) - DVec3::new(0.5, -2.0, 0.25)).length() < 1e-5);
    }
    assert_eq!(sample(&v, DVec3::new(-3.0, 100.0, 2.0)), sample(&v, DVec3::new(0.0, 6.0, 2.0)));
    // A 2D volume: bilinear, and no z gradient.
    let g2 = grid([6, 7, 1]);
    let v2 = Volume {
        grid: g2,
        data: (0..g2.len()).map(|i| f(g2.position(g2.voxel(i))) as f32).collect(),
    };
    let p = DVec3::new(2.5, 3.25, 0.7);
    assert!((f64::from(sample(&v2, p)) - f(DVec3::new(2.5, 3.25, 0.0))).abs() < 1e-5);
    assert_eq!(gradient(&v2, p).z, 0.0);
    // On a signed distance, the gradient points inside (uphill).
    let ball = Volume {
        grid: grid([21, 21, 21]),
        data: (0..21 * 21 * 21)
            .map(|i| {
                grid([21; 3]).position(grid([21; 3]).voxel(i)).distance(DVec3::splat(10.0)) < 6.0
            })
            .collect(),
    };
    let sd = signed_distance(&ball);
    let q = DVec3::new(14.2, 11.0, 9.5);
    assert!(gradient(&sd, q).dot(DVec3::splat(10.0) - q) > 0.0);
}
