//! `dexwarp.Demo`: a validated demonstration, from a `dexwarp.demo/1` file or from arrays.

use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::math::rotation::quat_to_wxyz;
use dexwarp::model::demo::{ContactJson, DemoFile, FrameJson, ObjectJson, PoseJson};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays;

/// The label of a demonstration built from arrays, in messages and provenance.
pub const ARRAYS: &str = "<arrays>";

/// A demonstration (`dexwarp.demo/1`): object and wrist poses, joint angles and contact
/// correspondences per frame, with the robot (URDF) and object mesh it refers to.
///
/// Immutable; build a new one with `Demo.from_arrays` to change it. Quaternions are
/// `[w, x, y, z]`, lengths metres, angles radians.
#[pyclass(frozen, module = "dexwarp")]
#[derive(Clone, Debug)]
pub struct Demo {
    pub inner: dexwarp::model::Demo,
}

fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
}

#[pymethods]
impl Demo {
    /// Reads and validates a demonstration file (`dexwarp.demo/1`); paths inside it are
    /// relative to it. Raises DexwarpError naming the file and field on bad input.
    #[staticmethod]
    fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Demo> {
        let path = path_of(path)?;
        let inner = py
            .detach(|| dexwarp::model::Demo::load(&path, &Limits::default()))
            .map_err(crate::to_py)?;
        Ok(Demo { inner })
    }

    /// A demonstration from arrays, checked exactly as a file with that content would be
    /// (messages name `<arrays>` and the field, e.g. `frames[3].joints[2]`).
    ///
    /// T frames, D joints, K contact correspondences in all:
    /// object_positions (T, 3) [m], object_quaternions (T, 4) [w, x, y, z], wrist_positions
    /// (T, 3), wrist_quaternions (T, 4), joints (T, D) in the order of joint_names;
    /// contacts as one row each: contact_frames (K,) frame index, contact_links K link
    /// names, contact_hand_points (K, 3) in the link frame, contact_object_points (K, 3) in
    /// the object frame. robot (URDF) and object_mesh (OBJ/STL) are paths, relative to the
    /// current folder; scene and barriers name the scene `validate` replays it in.
    #[staticmethod]
    #[pyo3(signature = (
        *, name, fps, robot, object_mesh, object_mass, joint_names,
        object_positions, object_quaternions, wrist_positions, wrist_quaternions, joints,
        contact_frames=None, contact_links=None, contact_hand_points=None,
        contact_object_points=None, object_name=None, scene=None, barriers=None
    ))]
    fn from_arrays(
        py: Python<'_>,
        name: String,
        fps: f64,
        robot: &Bound<'_, PyAny>,
        object_mesh: &Bound<'_, PyAny>,
        object_mass: f64,
        joint_names: Vec<String>,
        object_positions: &Bound<'_, PyAny>,
        object_quaternions: &Bound<'_, PyAny>,
        wrist_positions: &Bound<'_, PyAny>,
        wrist_quaternions: &Bound<'_, PyAny>,
        joints: &Bound<'_, PyAny>,
        contact_frames: Option<&Bound<'_, PyAny>>,
        contact_links: Option<Vec<String>>,
        contact_hand_points: Option<&Bound<'_, PyAny>>,
        contact_object_points: Option<&Bound<'_, PyAny>>,
        object_name: Option<String>,
        scene: Option<&Bound<'_, PyAny>>,
        barriers: Option<Vec<String>>,
    ) -> PyResult<Demo> {
        let l = ARRAYS;
        let (t, op) = arrays::matrix(object_positions, l, "object_positions", None, 3)?;
        let (_, oq) = arrays::matrix(object_quaternions, l, "object_quaternions", Some(t), 4)?;
        let (_, wp) = arrays::matrix(wrist_positions, l, "wrist_positions", Some(t), 3)?;
        let (_, wq) = arrays::matrix(wrist_quaternions, l, "wrist_quaternions", Some(t), 4)?;
        let dof = joint_names.len();
        let (_, q) = arrays::matrix(joints, l, "joints", Some(t), dof)?;

        let mut frames: Vec<FrameJson> = (0..t)
            .map(|i| FrameJson {
                object: PoseJson {
                    position: [op[3 * i], op[3 * i + 1], op[3 * i + 2]],
                    orientation: [oq[4 * i], oq[4 * i + 1], oq[4 * i + 2], oq[4 * i + 3]],
                },
                wrist: PoseJson {
                    position: [wp[3 * i], wp[3 * i + 1], wp[3 * i + 2]],
                    orientation: [wq[4 * i], wq[4 * i + 1], wq[4 * i + 2], wq[4 * i + 3]],
                },
                joints: q[dof * i..dof * (i + 1)].to_vec(),
                contacts: Vec::new(),
            })
            .collect();

        let given = [
            contact_frames.is_some(),
            contact_links.is_some(),
            contact_hand_points.is_some(),
            contact_object_points.is_some(),
        ];
        if given.iter().any(|g| *g) {
            let (Some(cf), Some(links), Some(hp), Some(opts)) = (
                contact_frames,
                contact_links,
                contact_hand_points,
                contact_object_points,
            ) else {
                return Err(crate::invalid(
                    l,
                    "contact_frames",
                    "contacts need all four of contact_frames, contact_links, contact_hand_points and contact_object_points",
                ));
            };
            let k = links.len();
            let cf = arrays::vector(cf, l, "contact_frames", Some(k))?;
            let (_, hp) = arrays::matrix(hp, l, "contact_hand_points", Some(k), 3)?;
            let (_, opts) = arrays::matrix(opts, l, "contact_object_points", Some(k), 3)?;
            for (j, (&f, link)) in cf.iter().zip(links).enumerate() {
                if !(f >= 0.0 && f.fract() == 0.0 && f < t as f64) {
                    return Err(crate::invalid(
                        l,
                        &format!("contact_frames[{j}]"),
                        format!(
                            "is {f}; expected a frame index from 0 to {}",
                            t.saturating_sub(1)
                        ),
                    ));
                }
                frames[f as usize].contacts.push(ContactJson {
                    link,
                    hand_point: [hp[3 * j], hp[3 * j + 1], hp[3 * j + 2]],
                    object_point: [opts[3 * j], opts[3 * j + 1], opts[3 * j + 2]],
                });
            }
        }
        let mesh = path_of(object_mesh)?;
        let file = DemoFile {
            format: dexwarp::model::demo::DEMO_FORMAT.into(),
            name,
            fps,
            robot: path_of(robot)?,
            wrist_link: None,
            object: ObjectJson {
                name: object_name.unwrap_or_else(|| {
                    mesh.file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_default()
                }),
                mesh,
                mass: object_mass,
            },
            joint_names,
            frames,
            timewarp: None,
            scene: scene.map(path_of).transpose()?,
            barriers: barriers.unwrap_or_default(),
        };
        let inner = py
            .detach(|| dexwarp::model::Demo::from_file(file, Path::new(ARRAYS), &Limits::default()))
            .map_err(crate::to_py)?;
        Ok(Demo { inner })
    }

    /// Writes the demonstration as a `dexwarp.demo/1` file (atomically; paths inside it
    /// relative to it).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = path_of(path)?;
        py.detach(|| self.inner.save(&path)).map_err(crate::to_py)
    }

    /// Name of the demonstration.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Frame rate [Hz].
    #[getter]
    fn fps(&self) -> f64 {
        self.inner.fps
    }

    /// Number of frames.
    fn __len__(&self) -> usize {
        self.inner.frames.len()
    }

    /// The file the demonstration was read from (`<arrays>` when built from arrays).
    #[getter]
    fn source(&self) -> PathBuf {
        self.inner.source.clone()
    }

    /// URDF of the hand (resolved path).
    #[getter]
    fn robot(&self) -> PathBuf {
        self.inner.robot.clone()
    }

    /// Object mesh (resolved path).
    #[getter]
    fn object_mesh(&self) -> PathBuf {
        self.inner.object.mesh.clone()
    }

    /// Object name.
    #[getter]
    fn object_name(&self) -> &str {
        &self.inner.object.name
    }

    /// Object mass [kg].
    #[getter]
    fn object_mass(&self) -> f64 {
        self.inner.object.mass
    }

    /// Actuated joints, in the order of the columns of `joints`.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.inner.joint_names.clone()
    }

    /// Scene the demonstration names (resolved path), or None.
    #[getter]
    fn scene(&self) -> Option<PathBuf> {
        self.inner.scene.clone()
    }

    /// Scene items the demonstration must avoid (`validate` checks them).
    #[getter]
    fn barriers(&self) -> Vec<String> {
        self.inner.barriers.clone()
    }

    /// Object positions, shape (T, 3) [m].
    #[getter]
    fn object_positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.inner.frames;
        arrays::rows_out(py, f.iter().map(|f| f.object.translation.vector.into()))
    }

    /// Object orientations, shape (T, 4), [w, x, y, z].
    #[getter]
    fn object_quaternions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.inner.frames;
        arrays::rows_out(py, f.iter().map(|f| quat_to_wxyz(&f.object.rotation)))
    }

    /// Wrist positions, shape (T, 3) [m].
    #[getter]
    fn wrist_positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.inner.frames;
        arrays::rows_out(py, f.iter().map(|f| f.wrist.translation.vector.into()))
    }

    /// Wrist orientations, shape (T, 4), [w, x, y, z].
    #[getter]
    fn wrist_quaternions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.inner.frames;
        arrays::rows_out(py, f.iter().map(|f| quat_to_wxyz(&f.wrist.rotation)))
    }

    /// Joint values, shape (T, D) [rad, or m for prismatic joints], columns as `joint_names`.
    #[getter]
    fn joints<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<&[f64]> = self
            .inner
            .frames
            .iter()
            .map(|f| f.joints.as_slice())
            .collect();
        arrays::table_out(py, &rows, self.inner.joint_names.len())
    }

    /// Frame index of each contact correspondence, shape (K,).
    #[getter]
    fn contact_frames<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self
            .inner
            .frames
            .iter()
            .enumerate()
            .flat_map(|(i, f)| std::iter::repeat_n(i as i64, f.contacts.len()))
            .collect();
        v.into_pyarray(py)
    }

    /// Link name of each contact correspondence (K names).
    #[getter]
    fn contact_links(&self) -> Vec<String> {
        self.contacts().map(|c| c.link.clone()).collect()
    }

    /// Hand point of each correspondence in its link's frame, shape (K, 3) [m].
    #[getter]
    fn contact_hand_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<[f64; 3]> = self
            .contacts()
            .map(|c| c.hand_point.coords.into())
            .collect();
        arrays::rows_out(py, rows.into_iter())
    }

    /// Object point of each correspondence in the object's frame, shape (K, 3) [m].
    #[getter]
    fn contact_object_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<[f64; 3]> = self
            .contacts()
            .map(|c| c.object_point.coords.into())
            .collect();
        arrays::rows_out(py, rows.into_iter())
    }

    /// τ: the output frame time of each input frame (warped outputs), or None.
    #[getter]
    fn timewarp<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .timewarp
            .clone()
            .map(|t| arrays::vector_out(py, t))
    }

    fn __repr__(&self) -> String {
        format!(
            "Demo(name={:?}, frames={}, joints={}, source={:?})",
            self.inner.name,
            self.inner.frames.len(),
            self.inner.joint_names.len(),
            self.inner.source.display().to_string()
        )
    }
}

impl Demo {
    fn contacts(&self) -> impl Iterator<Item = &dexwarp::model::Contact> {
        self.inner.frames.iter().flat_map(|f| f.contacts.iter())
    }
}
