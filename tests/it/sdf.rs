//! The object signed distance field against its exact reference on every built-in object.

use dexwarp::Limits;
use dexwarp::geometry::{Mesh, ObjectSdf, SdfParams};
use nalgebra::{Point3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::fixtures::repo;

/// Distance from the surface within which the grid is held to its bound: the band of exact
/// samples (6 mm) less a cell diagonal (3.5 mm); farther out it is a lower bound.
const ACCURATE_M: f64 = 0.0025;

const OBJECTS: [&str; 6] = ["apple", "cube", "frying_pan", "mug", "small_box", "teapot"];

/// Within 2.5 mm of the surface the grid's value is within its documented bound of the exact
/// signed distance, with the same sign wherever the exact value is farther than that bound
/// from zero; the build is quick and the parity scan is clean.
#[test]
fn grid_matches_the_exact_distance() {
    for name in OBJECTS {
        let path = repo(&format!("scenes/objects/{name}.obj"));
        let mesh = Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).unwrap();
        let sdf = ObjectSdf::new(mesh.clone(), &SdfParams::default()).unwrap();
        assert_eq!(sdf.parity_errors(), 0, "{name}: parity errors");
        assert_eq!(sdf.open_parts(), 0, "{name}: open parts");
        let bound = sdf.grid_error_bound_m();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut worst, mut sum, mut count) = (0.0f64, 0.0, 0usize);
        let mut worst_at = (Point3::origin(), 0.0, 0.0);
        // Points near the surface: a random vertex or triangle point, moved along a random
        // direction by up to 5 mm; plus deep points.
        for _ in 0..4000 {
            let t = mesh.triangles[rng.random_range(0..mesh.triangles.len())];
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize].coords);
            let on = a + (b - a) * u + (c - a) * v;
            let dir = Vector3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            )
            .normalize();
            let p = Point3::from(on + dir * rng.random_range(-0.012..0.012));
            let exact = sdf.exact().surface_point(&p).signed_distance;
            if exact.abs() > ACCURATE_M {
                continue;
            }
            let grid = sdf.distance(&p);
            let err = (grid - exact).abs();
            if err > worst {
                worst = err;
                worst_at = (p, exact, grid);
            }
            sum += err;
            count += 1;
            if exact.abs() > bound {
                assert_eq!(
                    grid.signum(),
                    exact.signum(),
                    "{name}: sign at {p:?}: grid {grid} exact {exact}"
                );
            }
        }
        println!(
            "{name}: {count} points, max error {:.3} mm, mean {:.4} mm, build {:.1} ms, spacing {} mm",
            worst * 1e3,
            sum / count as f64 * 1e3,
            sdf.build_s * 1e3,
            sdf.spacing_m() * 1e3
        );
        assert!(
            sum / (count as f64) < 0.1 * bound,
            "{name}: mean grid error {:.4} mm",
            sum / count as f64 * 1e3
        );
        assert!(
            worst <= bound,
            "{name}: max grid error {:.3} mm above the bound {:.3} mm at {worst_at:?}",
            worst * 1e3,
            bound * 1e3
        );
    }
}
