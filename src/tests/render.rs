//! The renderers: a field drawn by ray marching and a mesh of the same shape drawn by the
//! rasterizer must show the same silhouette through the same camera; framing, background,
//! colours and PNG output.

use std::f64::consts::{PI, TAU};

use implicitize::render::{
    Camera, Coloring, Image, March, Shading, render_field, render_mesh, render_mesh_scalars,
};
use implicitize::{Aabb, DVec3, Field, mesh::Mesh};

/// A ball, positive inside.
struct Ball {
    center: DVec3,
    radius: f64,
}

impl Field for Ball {
    fn value(&self, p: DVec3) -> f64 {
        self.radius * self.radius - (p - self.center).length_squared()
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        -2.0 * (p - self.center)
    }
}

impl Ball {
    fn bounds(&self) -> Aabb {
        Aabb { min: self.center - self.radius, max: self.center + self.radius }
    }
}

/// A torus about the z axis, positive inside.
struct Torus {
    major: f64,
    minor: f64,
}

impl Field for Torus {
    fn value(&self, p: DVec3) -> f64 {
        let ring = (p.x * p.x + p.y * p.y).sqrt() - self.major;
        self.minor * self.minor - ring * ring - p.z * p.z
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let q = (p.x * p.x + p.y * p.y).sqrt().max(1e-12);
        let ring = q - self.major;
        DVec3::new(-2.0 * ring * p.x / q, -2.0 * ring * p.y / q, -2.0 * p.z)
    }
}

impl Torus {
    fn bounds(&self) -> Aabb {
        let r = self.major + self.minor;
        Aabb { min: DVec3::new(-r, -r, -self.minor), max: DVec3::new(r, r, self.minor) }
    }
}

/// An ellipsoid, positive inside.
struct Ellipsoid {
    center: DVec3,
    radii: DVec3,
}

impl Field for Ellipsoid {
    fn value(&self, p: DVec3) -> f64 {
        1.0 - ((p - self.center) / self.radii).length_squared()
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        -2.0 * (p - self.center) / (self.radii * self.radii)
    }
}

/// A field that is the same everywhere.
struct Constant(f64);

impl Field for Constant {
    fn value(&self, _: DVec3) -> f64 {
        self.0
    }
    fn gradient(&self, _: DVec3) -> DVec3 {
        DVec3::ZERO
    }
}

/// A closed mesh of the surface `point(u, v)` on a `nu` x `nv` grid of the parameter square,
/// periodic in both (a torus) or with `v` running pole to pole (a sphere, `poles`).
fn parametric(nu: usize, nv: usize, poles: bool, point: impl Fn(f64, f64) -> DVec3) -> Mesh {
    let rows = if poles { nv + 1 } else { nv };
    let mut vertices = Vec::new();
    for j in 0..rows {
        for i in 0..nu {
            vertices.push(point(i as f64 / nu as f64, j as f64 / nv as f64));
        }
    }
    let id = |i: usize, j: usize| ((j % rows) * nu + i % nu) as u32;
    let mut triangles = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh { vertices, triangles }
}

fn uv_sphere(ball: &Ball, nu: usize, nv: usize) -> Mesh {
    parametric(nu, nv, true, |u, v| {
        let (theta, phi) = (TAU * u, PI * v);
        ball.center
            + ball.radius * DVec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin())
    })
}

fn uv_torus(torus: &Torus, nu: usize, nv: usize) -> Mesh {
    parametric(nu, nv, false, |u, v| {
        let (a, b) = (TAU * u, TAU * v);
        let ring = torus.major + torus.minor * b.cos();
        DVec3::new(ring * a.cos(), ring * a.sin(), torus.minor * b.sin())
    })
}

fn intersection_over_union(a: &Image, b: &Image) -> f64 {
    let (a, b) = (a.coverage(), b.coverage());
    let both = a.iter().zip(&b).filter(|(x, y)| **x && **y).count();
    let either = a.iter().zip(&b).filter(|(x, y)| **x || **y).count();
    both as f64 / either as f64
}

fn covered(image: &Image) -> usize {
    image.coverage().iter().filter(|&&c| c).count()
}

#[test]
fn a_ball_and_its_mesh_show_the_same_silhouette_and_shading() {
    let ball = Ball { center: DVec3::new(3.0, -2.0, 1.0), radius: 0.8 };
    let camera = Camera::framing(&ball.bounds(), 35.0, 20.0, 240, 200).unwrap();
    let field =
        render_field(&ball, &ball.bounds(), &camera, Coloring::Plain, March::default()).unwrap();
    let mesh = render_mesh(&uv_sphere(&ball, 256, 128), &camera, Coloring::Plain, Shading::Smooth);
    assert!(covered(&field) > 240 * 200 / 5, "the ball fills the frame: {}", covered(&field));
    let iou = intersection_over_union(&field, &mesh);
    assert!(iou >= 0.98, "intersection over union {iou}");
    // Same light and camera: colours agree where both show the ball.
    let (mut sum, mut n) = (0.0, 0);
    for (p, q) in field.rgba.chunks_exact(4).zip(mesh.rgba.chunks_exact(4)) {
        if p[3] != 0 && q[3] != 0 {
            sum += (0..3).map(|c| (p[c] as f64 - q[c] as f64).abs()).sum::<f64>() / 3.0;
            n += 1;
        }
    }
    assert!(sum / (n as f64) < 2.0, "mean colour difference {}", sum / n as f64);
}

#[test]
fn a_torus_and_its_mesh_show_the_same_silhouette_with_the_hole() {
    let torus = Torus { major: 1.0, minor: 0.35 };
    let mesh = uv_torus(&torus, 256, 96);
    for (azimuth, elevation, hole) in [(20.0, 50.0, true), (-60.0, 15.0, false), (0.0, 90.0, false)]
    {
        let camera = Camera::framing(&torus.bounds(), azimuth, elevation, 200, 160).unwrap();
        let field =
            render_field(&torus, &torus.bounds(), &camera, Coloring::Normals, March::default())
                .unwrap();
        let drawn = render_mesh(&mesh, &camera, Coloring::Normals, Shading::Flat);
        let iou = intersection_over_union(&field, &drawn);
        assert!(iou >= 0.98, "view ({azimuth}, {elevation}): intersection over union {iou}");
        if hole {
            // The hole shows: the torus's centre projects to the frame's centre, empty in both.
            let (x, y, _) = camera.project(DVec3::ZERO);
            let (x, y) = (x as usize, y as usize);
            assert_eq!(field.pixel(x, y).unwrap()[3], 0);
            assert_eq!(drawn.pixel(x, y).unwrap()[3], 0);
        }
    }
}

/// The union of two fields: inside either.
struct Union<A, B>(A, B);

impl<A: Field, B: Field> Field for Union<A, B> {
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p).max(self.1.value(p))
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        if self.0.value(p) >= self.1.value(p) { self.0.gradient(p) } else { self.1.gradient(p) }
    }
}

fn merged(a: Mesh, b: Mesh) -> Mesh {
    let offset = a.vertices.len() as u32;
    let mut mesh = a;
    mesh.vertices.extend(b.vertices);
    mesh.triangles.extend(b.triangles.iter().map(|t| t.map(|v| v + offset)));
    mesh
}

/// A flat disc about the y axis: the intersection of a slab and a cylinder, positive inside.
struct Slab {
    center: DVec3,
    radius: f64,
    half_thickness: f64,
}

impl Slab {
    fn parts(&self, p: DVec3) -> (f64, f64) {
        let q = p - self.center;
        (self.half_thickness - q.y.abs(), self.radius - (q.x * q.x + q.z * q.z).sqrt())
    }

    /// Top and bottom fans and the side band, `n` segments around.
    fn mesh(&self, n: usize) -> Mesh {
        let mut vertices = vec![
            self.center + self.half_thickness * DVec3::Y,
            self.center - self.half_thickness * DVec3::Y,
        ];
        for i in 0..n {
            let a = TAU * i as f64 / n as f64;
            let rim = self.center + self.radius * DVec3::new(a.cos(), 0.0, a.sin());
            vertices.push(rim + self.half_thickness * DVec3::Y);
            vertices.push(rim - self.half_thickness * DVec3::Y);
        }
        let rim = |i: usize, bottom: u32| (2 + 2 * (i % n)) as u32 + bottom;
        let mut triangles = Vec::new();
        for i in 0..n {
            triangles.push([0, rim(i + 1, 0), rim(i, 0)]);
            triangles.push([1, rim(i, 1), rim(i + 1, 1)]);
            triangles.push([rim(i, 0), rim(i + 1, 0), rim(i + 1, 1)]);
            triangles.push([rim(i, 0), rim(i + 1, 1), rim(i, 1)]);
        }
        Mesh { vertices, triangles }
    }
}

impl Field for Slab {
    fn value(&self, p: DVec3) -> f64 {
        let (a, b) = self.parts(p);
        a.min(b)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (a, b) = self.parts(p);
        let q = p - self.center;
        if a <= b {
            DVec3::new(0.0, -q.y.signum(), 0.0)
        } else {
            -DVec3::new(q.x, 0.0, q.z).normalize_or_zero()
        }
    }
}

#[test]
fn thin_and_small_parts_are_not_lost() {
    // A flat disc 3 march steps thick, off the lattice's planes, seen from the side and above.
    let slab = Slab { center: DVec3::new(0.1, 0.0123, -0.05), radius: 1.0, half_thickness: 0.023 };
    let bounds = Aabb {
        min: slab.center - DVec3::new(1.0, 0.023, 1.0),
        max: slab.center + DVec3::new(1.0, 0.023, 1.0),
    };
    for elevation in [20.0, 45.0] {
        let camera = Camera::framing(&bounds, 30.0, elevation, 200, 150).unwrap();
        let field =
            render_field(&slab, &bounds, &camera, Coloring::Plain, March::default()).unwrap();
        let drawn = render_mesh(&slab.mesh(256), &camera, Coloring::Plain, Shading::Flat);
        let iou = intersection_over_union(&field, &drawn);
        assert!(iou >= 0.98, "thin disc at elevation {elevation}: intersection over union {iou}");
    }

    let big = Ball { center: DVec3::ZERO, radius: 1.0 };
    let small = Ball { center: DVec3::new(1.5, 0.5, 0.3), radius: 0.035 };
    let bounds = Aabb { min: DVec3::splat(-1.0), max: DVec3::new(1.535, 1.0, 1.0) };
    let camera = Camera::framing(&bounds, 0.0, 0.0, 300, 200).unwrap();
    let field =
        render_field(&Union(big, small), &bounds, &camera, Coloring::Plain, March::default())
            .unwrap();
    let big = Ball { center: DVec3::ZERO, radius: 1.0 };
    let small = Ball { center: DVec3::new(1.5, 0.5, 0.3), radius: 0.035 };
    let drawn = render_mesh(
        &merged(uv_sphere(&big, 256, 128), uv_sphere(&small, 64, 32)),
        &camera,
        Coloring::Plain,
        Shading::Smooth,
    );
    let (x, y, _) = camera.project(small.center);
    assert_eq!(field.pixel(x as usize, y as usize).unwrap()[3], 255, "the small ball shows");
    let iou = intersection_over_union(&field, &drawn);
    assert!(iou >= 0.98, "two balls: intersection over union {iou}");
}

#[test]
fn the_background_is_empty_outside_the_ball() {
    let ball = Ball { center: DVec3::new(-5.0, 0.5, 2.0), radius: 1.5 };
    // Framed on a larger box, so there is background all around the ball.
    let bounds = Aabb { min: ball.center - 3.0, max: ball.center + 3.0 };
    let (width, height) = (160, 120);
    let camera = Camera::framing(&bounds, 10.0, -25.0, width, height).unwrap();
    let distance = (camera.eye() - ball.center).length();
    let angle = (ball.radius / distance).asin();
    let radius_px = angle.tan() / camera.tan_half_fov_y() * height as f64 / 2.0;
    let field = render_field(&ball, &bounds, &camera, Coloring::Plain, March::default()).unwrap();
    let mesh = render_mesh(&uv_sphere(&ball, 256, 128), &camera, Coloring::Plain, Shading::Smooth);
    for image in [&field, &mesh] {
        for y in 0..height {
            for x in 0..width {
                let r = ((x as f64 + 0.5 - width as f64 / 2.0).powi(2)
                    + (y as f64 + 0.5 - height as f64 / 2.0).powi(2))
                .sqrt();
                let alpha = image.pixel(x, y).unwrap()[3];
                if r > radius_px + 1.5 {
                    assert_eq!(
                        image.pixel(x, y).unwrap(),
                        [0, 0, 0, 0],
                        "({x}, {y}) is background"
                    );
                } else if r < radius_px - 1.5 {
                    assert_eq!(alpha, 255, "({x}, {y}) shows the ball");
                }
            }
        }
    }
    // A field with no inside draws nothing; one with no outside shows the clipping box.
    let empty =
        render_field(&Constant(-1.0), &bounds, &camera, Coloring::Plain, March::default()).unwrap();
    assert_eq!(covered(&empty), 0);
    let full =
        render_field(&Constant(1.0), &bounds, &camera, Coloring::Plain, March::default()).unwrap();
    assert_eq!(full.pixel(width / 2, height / 2).unwrap()[3], 255);
    assert_eq!(full.pixel(0, 0).unwrap()[3], 0);
}

#[test]
fn a_shape_framed_on_its_bounds_sits_in_the_middle_of_the_frame() {
    let shape =
        Ellipsoid { center: DVec3::new(100.0, -40.0, 7.0), radii: DVec3::new(3.0, 1.0, 0.5) };
    let bounds = Aabb { min: shape.center - shape.radii, max: shape.center + shape.radii };
    for (azimuth, elevation, width, height) in
        [(0.0, 0.0, 200, 100), (45.0, 30.0, 120, 160), (200.0, -70.0, 150, 150)]
    {
        let camera = Camera::framing(&bounds, azimuth, elevation, width, height).unwrap();
        let image =
            render_field(&shape, &bounds, &camera, Coloring::Plain, March::default()).unwrap();
        let coverage = image.coverage();
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
        let (mut lo, mut hi) = ([usize::MAX; 2], [0; 2]);
        for (i, _) in coverage.iter().enumerate().filter(|(_, c)| **c) {
            let (x, y) = (i % width, i / width);
            sx += x as f64 + 0.5;
            sy += y as f64 + 0.5;
            n += 1.0;
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        assert!(n > 0.0);
        let (cx, cy) = (sx / n / width as f64 - 0.5, sy / n / height as f64 - 0.5);
        // Perspective moves the nearer end's larger image off centre by a few percent.
        assert!(
            cx.abs() < 0.04 && cy.abs() < 0.04,
            "view ({azimuth}, {elevation}): centre of mass off by ({cx}, {cy})"
        );
        // The shape stays in the frame, and fills it along one axis at least halfway.
        assert!(lo[0] > 0 && lo[1] > 0 && hi[0] < width - 1 && hi[1] < height - 1);
        let fill =
            ((hi[0] - lo[0]) as f64 / width as f64).max((hi[1] - lo[1]) as f64 / height as f64);
        assert!(fill > 0.5, "view ({azimuth}, {elevation}): the shape fills {fill} of the frame");
    }
}

#[test]
fn normals_are_drawn_as_colours_facing_the_eye() {
    let ball = Ball { center: DVec3::ZERO, radius: 1.0 };
    // From +z: the middle of the picture faces +z, its right side +x, its top +y.
    let camera = Camera::framing(&ball.bounds(), 0.0, 0.0, 101, 101).unwrap();
    let field =
        render_field(&ball, &ball.bounds(), &camera, Coloring::Normals, March::default()).unwrap();
    let mesh =
        render_mesh(&uv_sphere(&ball, 256, 128), &camera, Coloring::Normals, Shading::Smooth);
    for image in [&field, &mesh] {
        let middle = image.pixel(50, 50).unwrap();
        assert!(
            middle[0].abs_diff(128) <= 3 && middle[1].abs_diff(128) <= 3 && middle[2] >= 252,
            "{middle:?}"
        );
        let right = image.pixel(80, 50).unwrap();
        assert!(right[0] > 190 && right[1].abs_diff(128) <= 3, "{right:?}");
        let top = image.pixel(50, 20).unwrap();
        assert!(top[1] > 190 && top[0].abs_diff(128) <= 3, "{top:?}");
    }
}

#[test]
fn scalars_run_from_red_where_small_to_green_where_large() {
    let ball = Ball { center: DVec3::ZERO, radius: 1.0 };
    let mesh = uv_sphere(&ball, 64, 32);
    let heights: Vec<f32> = mesh.vertices.iter().map(|p| p.y as f32).collect();
    let camera = Camera::framing(&ball.bounds(), 0.0, 0.0, 101, 101).unwrap();
    let image = render_mesh_scalars(&mesh, &heights, (-0.8, 0.8), &camera).unwrap();
    let top = image.pixel(50, 12).unwrap();
    let bottom = image.pixel(50, 88).unwrap();
    assert!(top[1] > top[0] + 40, "top is green: {top:?}");
    assert!(bottom[0] > bottom[1] + 40, "bottom is red: {bottom:?}");
    assert_eq!(
        covered(&image),
        covered(&render_mesh(&mesh, &camera, Coloring::Plain, Shading::Smooth))
    );
    assert!(render_mesh_scalars(&mesh, &heights[1..], (0.0, 1.0), &camera).is_err());
    assert!(render_mesh_scalars(&mesh, &heights, (1.0, 1.0), &camera).is_err());
    assert!(render_mesh_scalars(&mesh, &heights, (0.0, f32::NAN), &camera).is_err());
}

#[test]
fn a_png_written_reads_back_the_same() {
    let ball = Ball { center: DVec3::ZERO, radius: 1.0 };
    let camera = Camera::framing(&ball.bounds(), 20.0, 10.0, 70, 40).unwrap();
    let image =
        render_field(&ball, &ball.bounds(), &camera, Coloring::Plain, March::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ball.png");
    image.save_png(&path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut bytes).unwrap();
    assert_eq!((info.width, info.height), (70, 40));
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(&bytes[..info.buffer_size()], &image.rgba[..]);
    // An unwritable path and an empty picture are errors that name the file.
    let missing = dir.path().join("no/such/dir/ball.png");
    let err = image.save_png(&missing).unwrap_err().to_string();
    assert!(err.contains("ball.png"), "{err}");
    assert!(Image::empty(0, 5).save_png(&path).is_err());
}

#[test]
fn pictures_go_side_by_side() {
    let mut a = Image::empty(3, 2);
    a.rgba[..4].copy_from_slice(&[1, 2, 3, 255]);
    let mut b = Image::empty(2, 4);
    b.rgba[(3 * 2 + 1) * 4..].copy_from_slice(&[9, 8, 7, 255]);
    let strip = Image::side_by_side(&[a.clone(), b]);
    assert_eq!((strip.width, strip.height), (5, 4));
    assert_eq!(strip.pixel(0, 0), Some([1, 2, 3, 255]));
    assert_eq!(strip.pixel(4, 3), Some([9, 8, 7, 255]));
    assert_eq!(strip.pixel(1, 3), Some([0, 0, 0, 0]));
    assert_eq!(covered(&strip), 2);
    assert_eq!(Image::side_by_side(&[]).rgba.len(), 0);
    let with_empty = Image::side_by_side(&[Image::empty(0, 3), a]);
    assert_eq!((with_empty.width, with_empty.height), (3, 3));
    assert_eq!(with_empty.pixel(0, 0), Some([1, 2, 3, 255]));
}

#[test]
fn bad_cameras_boxes_and_meshes_are_errors_not_panics() {
    let unit = Aabb { min: DVec3::ZERO, max: DVec3::ONE };
    assert!(Camera::framing(&unit, 0.0, 0.0, 0, 10).is_err());
    assert!(Camera::framing(&unit, 0.0, 0.0, 10, Camera::MAX_SIDE + 1).is_err());
    assert!(Camera::framing(&unit, f64::NAN, 0.0, 10, 10).is_err());
    let nan = Aabb { min: DVec3::splat(f64::NAN), max: DVec3::ONE };
    assert!(Camera::framing(&nan, 0.0, 0.0, 10, 10).is_err());
    let camera = Camera::framing(&unit, 0.0, 0.0, 32, 32).unwrap();
    let ball = Ball { center: DVec3::ZERO, radius: 1.0 };
    let point = Aabb { min: DVec3::ONE, max: DVec3::ONE };
    assert!(render_field(&ball, &point, &camera, Coloring::Plain, March::default()).is_err());
    assert!(render_field(&ball, &nan, &camera, Coloring::Plain, March::default()).is_err());
    assert!(render_field(&ball, &unit, &camera, Coloring::Plain, March { cells: 0 }).is_err());
    let too_fine = March { cells: March::MAX_CELLS + 1 };
    assert!(render_field(&ball, &unit, &camera, Coloring::Plain, too_fine).is_err());
    // A degenerate box still frames; a field that is not a number draws nothing.
    assert!(Camera::framing(&point, 90.0, 90.0, 8, 8).is_ok());
    let nothing =
        render_field(&Constant(f64::NAN), &unit, &camera, Coloring::Plain, March::default())
            .unwrap();
    assert_eq!(covered(&nothing), 0);
    // Triangles with missing or non-finite corners are skipped; the good one is drawn.
    let mesh = Mesh {
        vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::splat(f64::NAN)],
        triangles: vec![[0, 1, 2], [0, 1, 7], [0, 3, 2]],
    };
    let drawn = render_mesh(&mesh, &camera, Coloring::Plain, Shading::Smooth);
    assert!(covered(&drawn) > 32 * 32 / 8);
    assert!(
        covered(&render_mesh(&Mesh::default(), &camera, Coloring::Normals, Shading::Flat)) == 0
    );
}
