//! Topology of triangle meshes: closedness, components, genus.

use std::collections::HashMap;

use implicitize::mesh::Mesh;

/// Every edge is used by exactly two triangles, once in each direction.
pub fn assert_closed(mesh: &Mesh, what: &str) {
    assert!(!mesh.triangles.is_empty(), "{what}: the mesh is empty");
    let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
    for &[a, b, c] in &mesh.triangles {
        for e in [(a, b), (b, c), (c, a)] {
            *edges.entry(e).or_insert(0) += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "{what}: edge ({a}, {b}) is used {n} times in the same direction");
        assert!(edges.contains_key(&(b, a)), "{what}: edge ({a}, {b}) has one triangle");
    }
}

/// The number of connected components of the mesh's triangles (sharing a vertex connects).
pub fn components(mesh: &Mesh) -> usize {
    let mut parent: Vec<usize> = (0..mesh.vertices.len()).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for t in &mesh.triangles {
        for &other in &t[1..] {
            let (a, b) = (root(&mut parent, t[0] as usize), root(&mut parent, other as usize));
            parent[a] = b;
        }
    }
    let mut roots: Vec<usize> =
        mesh.triangles.iter().map(|t| root(&mut parent, t[0] as usize)).collect();
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

/// The Euler characteristic V - E + F of a closed mesh: 2 for a sphere, 0 for a torus.
pub fn euler_characteristic(mesh: &Mesh) -> i64 {
    let mut used = vec![false; mesh.vertices.len()];
    for t in &mesh.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let vertices = used.iter().filter(|&&u| u).count() as i64;
    let faces = mesh.triangles.len() as i64;
    vertices - faces * 3 / 2 + faces
}
