//! URDF geometry: `<origin>` poses, `<collision>` elements and mesh files.
//!
//! Part of the [`super::urdf`] loader. Dimensions are checked (finite, positive; a capsule's
//! straight length may be zero), mesh paths are resolved relative to the URDF file, and each
//! mesh file is read once per load even when several links use it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::urdf::Loader;
use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::geometry::shape::{CollisionShape, ShapeKind};

impl Loader<'_> {
    /// An URDF `<origin xyz rpy>` as an isometry: `R = R_z(yaw) · R_y(pitch) · R_x(roll)`
    /// (fixed axes x, y, z), which is nalgebra's `from_euler_angles(roll, pitch, yaw)`.
    pub(super) fn pose(&self, o: &urdf_rs::Pose, field: &str) -> Result<Isometry3<f64>> {
        let (xyz, rpy) = (o.xyz.0, o.rpy.0);
        if !xyz.iter().chain(rpy.iter()).all(|c| c.is_finite()) {
            return Err(self.invalid(
                format!("{field} <origin>"),
                format!("xyz {xyz:?} rpy {rpy:?} is not finite; expected numbers"),
            ));
        }
        Ok(Isometry3::from_parts(
            Translation3::new(xyz[0], xyz[1], xyz[2]),
            UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
        ))
    }

    /// One `<collision>` element as a [`CollisionShape`] in the link frame. `field` names the
    /// element in errors (`link 'palm' collision[1]`). Dimensions must be finite and
    /// positive (a capsule's straight `length` may be 0: a sphere). A mesh is read once,
    /// scaled per axis, and re-wound outward when closed (a mirroring scale flips it).
    pub(super) fn collision(
        &mut self,
        c: &urdf_rs::Collision,
        field: &str,
    ) -> Result<CollisionShape> {
        let origin = self.pose(&c.origin, field)?;
        let positive = |what: &str, v: f64, allow_zero: bool| {
            if v.is_finite() && (v > 0.0 || (allow_zero && v == 0.0)) {
                Ok(v)
            } else {
                Err(self.invalid(
                    field,
                    format!(
                        "{what} is {v}; expected a {} number of metres",
                        if allow_zero {
                            "non-negative"
                        } else {
                            "positive"
                        }
                    ),
                ))
            }
        };
        let kind = match &c.geometry {
            urdf_rs::Geometry::Box { size } => {
                for (k, &s) in size.0.iter().enumerate() {
                    positive(&format!("<box size> component {k}"), s, false)?;
                }
                ShapeKind::Box {
                    size: Vector3::from(size.0),
                }
            }
            urdf_rs::Geometry::Sphere { radius } => ShapeKind::Sphere {
                radius: positive("<sphere radius>", *radius, false)?,
            },
            urdf_rs::Geometry::Cylinder { radius, length } => ShapeKind::Cylinder {
                radius: positive("<cylinder radius>", *radius, false)?,
                length: positive("<cylinder length>", *length, false)?,
            },
            urdf_rs::Geometry::Capsule { radius, length } => ShapeKind::Capsule {
                radius: positive("<capsule radius>", *radius, false)?,
                length: positive("<capsule length>", *length, true)?,
            },
            urdf_rs::Geometry::Mesh { filename, scale } => {
                let scale = Vector3::from(scale.map_or([1.0; 3], |s| s.0));
                if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                    return Err(self.invalid(
                        format!("{field} <mesh scale>"),
                        format!("scale {scale:?} must be finite and non-zero"),
                    ));
                }
                let path = self.resolve_mesh(filename, field)?;
                let unscaled = self.load_mesh(&path, field)?;
                let mut mesh = (*unscaled).clone();
                for v in &mut mesh.vertices {
                    v.coords.component_mul_assign(&scale);
                }
                // A negative scale determinant mirrors the mesh and flips its winding.
                mesh.orient_outward();
                ShapeKind::Mesh {
                    path,
                    scale,
                    mesh: Arc::new(mesh),
                }
            }
        };
        CollisionShape::new_link(kind, origin).ok_or_else(|| {
            self.invalid(
                field,
                "parry could not build a shape from this geometry (a mesh needs a part with volume)",
            )
        })
    }

    /// Finds a mesh file named in URDF. `package://pkg/rel` is searched as `rel` and `pkg/rel`
    /// under the URDF folder and each of its ancestors (ROS packages are not installed here);
    /// `file://` and plain paths are absolute or relative to the URDF folder.
    pub(super) fn resolve_mesh(&self, filename: &str, field: &str) -> Result<PathBuf> {
        let mut candidates: Vec<PathBuf> = Vec::new();
        if let Some(rest) = filename.strip_prefix("package://") {
            let rel = rest.split_once('/').map_or(rest, |(_, r)| r);
            for dir in self.base_dir.ancestors() {
                candidates.push(dir.join(rel));
                candidates.push(dir.join(rest));
            }
        } else {
            let plain = filename.strip_prefix("file://").unwrap_or(filename);
            candidates.push(self.base_dir.join(plain)); // join keeps absolute paths as they are
        }
        candidates.dedup();
        candidates
            .iter()
            .find(|p| p.is_file())
            .cloned()
            .ok_or_else(|| {
                let tried: Vec<String> = candidates
                    .iter()
                    .take(6)
                    .map(|p| p.display().to_string())
                    .collect();
                self.invalid(
                    format!("{field} <mesh filename=\"{filename}\">"),
                    format!(
                        "mesh file not found (tried {}); paths are relative to the URDF file",
                        tried.join(", ")
                    ),
                )
            })
    }

    /// Reads a mesh file (unscaled) through the per-load cache. Mesh errors are re-issued
    /// against the URDF file and element, keeping their kind (a size limit stays
    /// [`Error::TooLarge`] naming the mesh file and the flag that raises it).
    pub(super) fn load_mesh(&mut self, path: &Path, field: &str) -> Result<Arc<Mesh>> {
        if let Some(m) = self.mesh_cache.get(path) {
            return Ok(m.clone());
        }
        let mesh = Mesh::load(path, Vector3::repeat(1.0), self.limits).map_err(|e| {
            let field = format!("{field} <mesh>");
            match e {
                e @ Error::TooLarge { .. } => e,
                Error::Unsupported { .. } => Error::unsupported(self.path, field, e.to_string()),
                e => Error::invalid(self.path, field, e.to_string()),
            }
        })?;
        let mesh = Arc::new(mesh);
        self.mesh_cache.insert(path.to_path_buf(), mesh.clone());
        Ok(mesh)
    }
}
