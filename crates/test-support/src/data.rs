//! The repository's data: the built-in triceratops and the files of `tests/data`.

use std::path::{Path, PathBuf};
use std::sync::LazyLock;

use implicitize::rbf::read_constraints;
use implicitize::{Aabb, DVec3, rbf::Implicit, rbf::Kernel};

/// The repository's root directory: the nearest folder above the compiling package's that
/// holds `data/triceratops.obj` (this source is compiled as the crate test-support and as a
/// module of the library's own tests, whose packages lie at different depths).
pub fn root() -> &'static Path {
    static ROOT: LazyLock<PathBuf> = LazyLock::new(|| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .ancestors()
            .find(|folder| folder.join("data/triceratops.obj").is_file())
            .expect("the repository's data/triceratops.obj above the package")
            .to_path_buf()
    });
    &ROOT
}

/// The built-in triceratops, `data/triceratops.obj` (closed, 5,660 triangles).
pub fn triceratops() -> &'static Path {
    static PATH: LazyLock<PathBuf> = LazyLock::new(|| root().join("data/triceratops.obj"));
    &PATH
}

/// A file of `tests/data` (reference values from SciPy and the bunny's constraints).
pub fn test_data(name: &str) -> PathBuf {
    root().join("tests/data").join(name)
}

/// The Stanford bunny's 700 constraints (`tests/data/bunny_constraints.csv`) solved with the
/// thin-plate kernel, and the bounds of their positions.
pub fn bunny() -> (Implicit, Aabb) {
    let (dim, constraints) =
        read_constraints(&test_data("bunny_constraints.csv")).expect("the bunny's constraints");
    let implicit = Implicit::solve(dim, Kernel::ThinPlate, &constraints).expect("a solved bunny");
    let positions: Vec<DVec3> =
        constraints.iter().map(|c| DVec3::from_slice(c.position())).collect();
    (implicit, Aabb::of_points(&positions).expect("constraints"))
}
