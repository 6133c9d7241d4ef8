//! Object signed distance field: build time per built-in object and query time.
//!
//! Target (release): build < 200 ms per object. Run with `cargo bench --bench sdf`.

use std::hint::black_box;
use std::path::Path;

use dexwarp::Limits;
use dexwarp::geometry::{Mesh, ObjectSdf, SdfParams};
use nalgebra::{Point3, Vector3};

fn main() {
    divan::main();
}

fn mesh(name: &str) -> Mesh {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/objects/{name}.obj"));
    Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).expect("object mesh loads")
}

#[divan::bench(args = ["apple", "cube", "frying_pan", "mug", "small_box", "teapot"], sample_count = 5)]
fn build(bencher: divan::Bencher, name: &str) {
    let m = mesh(name);
    bencher.bench(|| ObjectSdf::new(black_box(m.clone()), &SdfParams::default()));
}

/// 1,000 grid queries (value and gradient) on points near the mug's surface.
#[divan::bench]
fn query_1000(bencher: divan::Bencher) {
    let m = mesh("mug");
    let sdf = ObjectSdf::new(m.clone(), &SdfParams::default()).unwrap();
    let pts: Vec<Point3<f64>> = m
        .vertices
        .iter()
        .cycle()
        .take(1000)
        .enumerate()
        .map(|(i, v)| v + Vector3::new(0.001, -0.002, 0.0015) * ((i % 7) as f64 - 3.0) / 3.0)
        .collect();
    bencher.bench(|| {
        let mut s = 0.0;
        for p in &pts {
            s += sdf.distance_and_gradient(black_box(p)).0;
        }
        s
    });
}
