//! Scenes: fixed geometry with a role (the `dexwarp.scene/1` file format).
//!
//! Every item is a `barrier` (the object and hand must avoid it; the warp pushes the object
//! trajectory out of it) or a `support` (the object may rest on it: counters, shelves, plates).
//! Supports matter for physics only, never for the push-out (docs/METHOD.md, stage 2).
//! Shapes follow URDF conventions: a box has full `size`, cylinders and capsules have their
//! axis along the item's local z with total `length` (cylinder) or segment `length` (capsule).

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::json::{self, FieldCheck};
use crate::limits::WORLD_HALF_EXTENT_M;
use crate::{Error, Limits, Result};

/// The `format` value of a scene file.
pub const SCENE_FORMAT: &str = "dexwarp.scene/1";

/// What an item is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Must be avoided by the object and the hand.
    Barrier,
    /// The object may rest on it.
    Support,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Barrier => "barrier",
            Role::Support => "support",
        }
    }
}

/// A primitive or mesh, as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeJson {
    /// Full edge lengths [m].
    Box {
        size: [f64; 3],
    },
    Sphere {
        radius: f64,
    },
    /// Axis along local z; `length` is the distance between the two cap centres.
    Capsule {
        radius: f64,
        length: f64,
    },
    /// Axis along local z; `length` is the total height.
    Cylinder {
        radius: f64,
        length: f64,
    },
    /// OBJ or STL, relative to the scene file, scaled per axis.
    Mesh {
        path: PathBuf,
        #[serde(default = "unit_scale")]
        scale: [f64; 3],
    },
}

fn unit_scale() -> [f64; 3] {
    [1.0; 3]
}

/// A pose as stored in a scene (orientation optional, `[w, x, y, z]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenePoseJson {
    pub position: [f64; 3],
    #[serde(default = "identity_wxyz")]
    pub orientation: [f64; 4],
}

fn identity_wxyz() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// An item as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneItemJson {
    pub name: String,
    pub role: Role,
    pub pose: ScenePoseJson,
    pub shape: ShapeJson,
}

/// A scene file as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub format: String,
    pub name: String,
    pub items: Vec<SceneItemJson>,
}

/// A validated item; mesh paths are resolved against the scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneItem {
    pub name: String,
    pub role: Role,
    /// Pose of the item frame in the world.
    pub pose: Isometry3<f64>,
    pub shape: ShapeJson,
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: String,
    pub items: Vec<SceneItem>,
    pub source: PathBuf,
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path, limits: &Limits) -> Result<Scene> {
        let file: SceneFile = json::read_json_format(path, limits, SCENE_FORMAT)?;
        Scene::from_file(file, path)
    }

    /// Validates a parsed scene.
    pub fn from_file(file: SceneFile, path: &Path) -> Result<Scene> {
        let c = FieldCheck::new(path);
        if file.format != SCENE_FORMAT {
            return Err(Error::invalid(
                path,
                "format",
                format!(
                    "is {:?}; expected {SCENE_FORMAT:?} (is this a scene file?)",
                    file.format
                ),
            ));
        }
        let mut seen = std::collections::HashSet::new();
        let mut items = Vec::with_capacity(file.items.len());
        for (k, it) in file.items.into_iter().enumerate() {
            if !seen.insert(it.name.clone()) {
                return Err(Error::invalid(
                    path,
                    format!("items[{k}].name"),
                    format!("{:?} is used twice; item names must be unique", it.name),
                ));
            }
            let t = c.world_vec3(|| format!("items[{k}].pose.position"), it.pose.position)?;
            let r: UnitQuaternion<f64> = c.quaternion(
                || format!("items[{k}].pose.orientation"),
                it.pose.orientation,
            )?;
            let f = |name: &str| format!("items[{k}].shape.{name}");
            let shape = match it.shape {
                ShapeJson::Box { size } => {
                    for (a, &s) in size.iter().enumerate() {
                        c.size(|| format!("items[{k}].shape.size[{a}]"), s)?;
                    }
                    ShapeJson::Box { size }
                }
                ShapeJson::Sphere { radius } => {
                    c.size(|| f("radius"), radius)?;
                    ShapeJson::Sphere { radius }
                }
                ShapeJson::Capsule { radius, length } => {
                    c.size(|| f("radius"), radius)?;
                    c.non_negative(|| f("length"), length, "m")?;
                    c.in_range(
                        || f("length"),
                        length,
                        (0.0, 2.0 * WORLD_HALF_EXTENT_M),
                        "m",
                    )?;
                    ShapeJson::Capsule { radius, length }
                }
                ShapeJson::Cylinder { radius, length } => {
                    c.size(|| f("radius"), radius)?;
                    c.size(|| f("length"), length)?;
                    ShapeJson::Cylinder { radius, length }
                }
                ShapeJson::Mesh { path: p, scale } => {
                    for (a, &s) in scale.iter().enumerate() {
                        c.positive(|| format!("items[{k}].shape.scale[{a}]"), s, "factor")?;
                        c.in_range(
                            || format!("items[{k}].shape.scale[{a}]"),
                            s,
                            (1e-6, 1e6),
                            "factor",
                        )?;
                    }
                    let resolved = json::resolve_relative(path, &p);
                    if !resolved.is_file() {
                        return Err(Error::invalid(
                            path,
                            f("path"),
                            format!(
                                "cannot open {} (paths are relative to the scene file)",
                                resolved.display()
                            ),
                        ));
                    }
                    ShapeJson::Mesh {
                        path: resolved,
                        scale,
                    }
                }
            };
            items.push(SceneItem {
                name: it.name,
                role: it.role,
                pose: Isometry3::from_parts(Translation3::from(t), r),
                shape,
            });
        }
        Ok(Scene {
            name: file.name,
            items,
            source: path.to_path_buf(),
        })
    }

    /// The item called `name`.
    pub fn item(&self, name: &str) -> Option<&SceneItem> {
        self.items.iter().find(|i| i.name == name)
    }

    /// Names of the items with `role`.
    pub fn names_with_role(&self, role: Role) -> Vec<String> {
        self.items
            .iter()
            .filter(|i| i.role == role)
            .map(|i| i.name.clone())
            .collect()
    }
}

impl Scene {
    /// An item as a collision shape in the world frame (see [`SceneItem::collision_shape`]).
    pub fn collision_shape(
        &self,
        item: &SceneItem,
        limits: &Limits,
    ) -> Result<crate::geometry::shape::CollisionShape> {
        item.collision_shape(&self.source, limits)
    }
}

impl SceneItem {
    /// The item as a collision shape in the world frame, the same representation as a robot
    /// link's collision geometry: the one builder of a scene item's shape, so the physics
    /// replay, the IK's barrier term and the push-out's hulls
    /// ([`CollisionShape::hull_points`](crate::geometry::shape::CollisionShape::hull_points))
    /// see the same geometry. Errors name `scene`, the file the item is from.
    pub fn collision_shape(
        &self,
        scene: &Path,
        limits: &Limits,
    ) -> Result<crate::geometry::shape::CollisionShape> {
        use crate::geometry::shape::ShapeKind;
        let kind = match &self.shape {
            ShapeJson::Box { size } => ShapeKind::Box {
                size: nalgebra::Vector3::from(*size),
            },
            ShapeJson::Sphere { radius } => ShapeKind::Sphere { radius: *radius },
            ShapeJson::Capsule { radius, length } => ShapeKind::Capsule {
                radius: *radius,
                length: *length,
            },
            ShapeJson::Cylinder { radius, length } => ShapeKind::Cylinder {
                radius: *radius,
                length: *length,
            },
            ShapeJson::Mesh { path, scale } => {
                let scale = nalgebra::Vector3::from(*scale);
                let mesh = crate::geometry::Mesh::load(path, scale, limits)?;
                ShapeKind::Mesh {
                    path: path.clone(),
                    scale,
                    mesh: std::sync::Arc::new(mesh),
                }
            }
        };
        crate::geometry::shape::CollisionShape::new(kind, self.pose).ok_or_else(|| {
            Error::invalid(
                scene,
                format!("items[{:?}].shape", self.name),
                "the mesh has no triangles; expected a closed triangle mesh",
            )
        })
    }
}
