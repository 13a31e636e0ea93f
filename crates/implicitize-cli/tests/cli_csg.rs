//! `implicitize csg`: composites written by the command, read back by eval and mesh, and its
//! errors.

use std::path::Path;
use std::process::Command;

use implicitize::model::Model;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::{DVec3, Field};
use implicitize_test_support::models::{ball, disc_2d};
use implicitize_test_support::topology;

fn two_balls() -> (Model, Model) {
    (ball(DVec3::ZERO, 1.0, 1.0), ball(DVec3::new(1.1, 0.3, -0.2), 0.7, 3.0))
}

fn combine(op: Operation, blend: f64, a: &Model, b: &Model) -> Composite {
    Composite::new("test", op, blend, vec![Child::from(a.clone()), Child::from(b.clone())]).unwrap()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

fn run(args: &[&std::ffi::OsStr]) -> std::process::Output {
    implicitize().args(args).output().unwrap()
}

fn os(s: &(impl AsRef<std::ffi::OsStr> + ?Sized)) -> &std::ffi::OsStr {
    s.as_ref()
}

#[test]
fn the_command_line_writes_a_composite_that_eval_and_mesh_read() {
    let (a, b) = two_balls();
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    a.save(&p("a.json")).unwrap();
    b.save(&p("b.json")).unwrap();
    let out = run(&[
        os("csg"),
        os("difference"),
        os(&p("a.json")),
        os(&p("b.json")),
        os("-o"),
        os(&p("c.json")),
        os("--blend"),
        os("0.1"),
        os("--quiet"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let model = Model::load(&p("c.json")).unwrap();
    let want = combine(Operation::Difference, 0.1, &a, &b);
    let points =
        [DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.9, 0.3, -0.2), DVec3::new(3.0, 0.0, 0.0)];
    assert_eq!(bits(&model.values(&points)), bits(&want.values(&points)));
    std::fs::write(p("points.csv"), "x,y,z\n-0.5,0,0\n0.9,0.3,-0.2\n3,0,0\n").unwrap();
    let out = run(&[
        os("eval"),
        os(&p("c.json")),
        os("--points"),
        os(&p("points.csv")),
        os("-o"),
        os(&p("v.npy")),
        os("-q"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(p("v.npy")).unwrap();
    let values: Vec<f64> = npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap();
    let signs: Vec<bool> = values.iter().map(|&v| v > 0.0).collect();
    assert_eq!(signs, [true, false, false], "inside a only, inside both, outside: {values:?}");
    let out = run(&[
        os("mesh"),
        os(&p("c.json")),
        os("-o"),
        os(&p("c.ply")),
        os("--resolution"),
        os("40"),
        os("-q"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (surface, _) = implicitize::mesh::read(&p("c.ply")).unwrap();
    topology::assert_closed(&surface, "mesh of the composite");
}

fn stderr_of(args: &[&std::ffi::OsStr]) -> String {
    let out = run(args);
    assert!(!out.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn the_command_line_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    two_balls().0.save(&p("a.json")).unwrap();
    disc_2d().save(&p("disc.json")).unwrap();
    let e = stderr_of(&[
        os("csg"),
        os("xor"),
        os(&p("a.json")),
        os(&p("a.json")),
        os("-o"),
        os(&p("c.json")),
    ]);
    assert!(e.contains("xor") && e.contains("union"), "{e}");
    let e = stderr_of(&[
        os("csg"),
        os("union"),
        os(&p("a.json")),
        os(&p("none.json")),
        os("-o"),
        os(&p("c.json")),
    ]);
    assert!(e.contains("none.json"), "{e}");
    let e = stderr_of(&[
        os("csg"),
        os("union"),
        os(&p("a.json")),
        os(&p("disc.json")),
        os("-o"),
        os(&p("c.json")),
    ]);
    assert!(e.contains("2D") && e.contains("3D") && e.contains("disc.json"), "{e}");
    let e = stderr_of(&[
        os("csg"),
        os("union"),
        os(&p("a.json")),
        os(&p("a.json")),
        os("-o"),
        os(&p("c.json")),
        os("--blend"),
        os("-1"),
    ]);
    assert!(e.contains("blend") || e.contains("-1"), "{e}");
    assert!(!Path::new(&p("c.json")).exists(), "nothing is written on error");
}
