//! Shared test fixtures: a synthetic grasp demonstration on `robots/human_hand.urdf`.
//!
//! [`GraspDemo::build`] makes a demonstration whose correspondences are exact (D_C = 0 by
//! construction): the hand holds a curled grasp, the hand points are surface points of the
//! finger links that face the palm side, and each object point is `O⁻¹·FK(point)` at the
//! first in-contact frame. The object (the 6 cm cube of `synth::objects`, written as OBJ
//! into a temp dir) rests, is lifted, carried with a turn and placed; during contact the
//! hand is rigidly attached to it, or (with `in_hand_slide` / `in_hand_turn_rad`) slides
//! over it, the object points being recomputed every frame so D_C stays 0. Before contact the hand approaches with opening fingers,
//! after contact it retreats; those frames have no correspondences.
//!
//! Also: loading the human hand, building an object warp from waypoints (`warp`), and a
//! JSON config helper, so stage tests can share one path from demo to warped object.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::model::RetimeMode;
use dexwarp::model::config::{ConfigFile, WarpConfig};
use dexwarp::model::demo::ObjectInfo;
use dexwarp::model::{Contact, Demo, Frame, WarpParams};
use dexwarp::robot::Robot;
use dexwarp::synth::objects::{ObjectKind, object_mesh};
use dexwarp::warp::{ObjectParams, ObjectPath, ObjectWarp, WarpPlan, warp_object};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// `robots/human_hand.urdf` in this repository.
pub fn human_hand_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/human_hand.urdf")
}

/// The human hand, loaded.
pub fn human_hand() -> Robot {
    Robot::from_urdf_file(&human_hand_path(), &Limits::default()).expect("human_hand loads")
}

/// Shape of the synthetic demonstration.
#[derive(Clone, Debug)]
pub struct GraspOptions {
    /// Frames before the first contact (approach).
    pub pre: usize,
    /// In-contact frames (rest, lift, carry, place, rest).
    pub contact: usize,
    /// Frames after the last contact (retreat).
    pub post: usize,
    /// Correspondences per in-contact frame (at most the number of candidate points).
    pub contacts: usize,
    /// World position of the object at rest [m].
    pub start: Vector3<f64>,
    /// Object displacement of the carry [m] (the lift adds `lift_m` along z on the way).
    pub carry: Vector3<f64>,
    /// Height of the lift [m].
    pub lift_m: f64,
    /// Yaw of the object over the carry [rad].
    pub turn_rad: f64,
    /// In-hand motion over the contact segment: the hand slides by this much relative to the
    /// object (object frame) [m] ...
    pub in_hand_slide: Vector3<f64>,
    /// ... and turns about the object's z axis by this much [rad]; the object points are
    /// recomputed every frame (sliding contacts), so D_C stays exactly 0. Default: none.
    pub in_hand_turn_rad: f64,
}

impl Default for GraspOptions {
    fn default() -> Self {
        GraspOptions {
            pre: 20,
            contact: 160,
            post: 20,
            contacts: 50,
            start: Vector3::new(0.5, 0.0, 0.83),
            carry: Vector3::new(0.3, 0.1, 0.0),
            lift_m: 0.15,
            turn_rad: 0.5,
            in_hand_slide: Vector3::zeros(),
            in_hand_turn_rad: 0.0,
        }
    }
}

/// A synthetic demonstration with its robot and the temp dir holding the object mesh.
#[derive(Debug)]
pub struct GraspDemo {
    pub demo: Demo,
    pub robot: Robot,
    /// The grasp (robot joint order).
    pub grasp_q: Vec<f64>,
    /// Keeps the mesh file alive.
    pub dir: tempfile::TempDir,
}

/// A curled power grasp within the human hand's limits (robot joint order).
pub fn grasp_configuration(robot: &Robot) -> Vec<f64> {
    let mut q = vec![0.0; robot.dof()];
    for (i, name) in robot.actuated_names().iter().enumerate() {
        q[i] = match name.as_str() {
            n if n.ends_with("mcp_abd") => 0.0,
            n if n.ends_with("mcp_flex") && !n.starts_with("thumb") => 0.7,
            n if n.ends_with("pip_flex") => 0.8,
            n if n.ends_with("dip_flex") => 0.5,
            "thumb_cmc_abd" => 0.6,
            "thumb_cmc_flex" => 0.4,
            "thumb_mcp_flex" => 0.3,
            "thumb_ip_flex" => 0.4,
            _ => 0.0,
        };
    }
    robot.clamp(&mut q);
    q
}

/// Candidate hand points: surface points of the middle and distal finger links (and the
/// thumb's proximal and distal) whose normal faces the link's `+x` (the palm side),
/// as (link name, link-frame point), in robot link order.
pub fn candidate_points(robot: &Robot) -> Vec<(String, Point3<f64>)> {
    let mut out = Vec::new();
    for link in robot.links() {
        let n = &link.name;
        let wanted = n.ends_with("_distal")
            || n.ends_with("_middle")
            || (n.starts_with("thumb") && n.ends_with("_proximal"));
        if !wanted {
            continue;
        }
        for (p, nrm) in link.surface_points.iter().zip(&link.surface_normals) {
            if nrm.x > 0.5 {
                out.push((n.clone(), *p));
            }
        }
    }
    out
}

/// Smoothstep on [0, 1].
fn ease(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

impl GraspDemo {
    /// Builds the demonstration (see the module docs).
    pub fn build(opts: &GraspOptions) -> GraspDemo {
        let robot = human_hand();
        let dir = tempfile::tempdir().expect("temp dir");
        let mesh_path = dir.path().join("cube.obj");
        object_mesh(ObjectKind::Cube)
            .write_obj(&mesh_path)
            .expect("write cube");
        let grasp_q = grasp_configuration(&robot);
        let open_q = vec![0.0; robot.dof()];

        // Hand points, strided to the requested count, and where they sit at the grasp.
        let candidates = candidate_points(&robot);
        assert!(!candidates.is_empty(), "no candidate hand points");
        let count = opts.contacts.clamp(1, candidates.len());
        let picked: Vec<&(String, Point3<f64>)> = (0..count)
            .map(|k| &candidates[k * candidates.len() / count])
            .collect();
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&Isometry3::identity(), &grasp_q, &mut poses);
        let in_hand: Vec<Point3<f64>> = picked
            .iter()
            .map(|(l, p)| poses[robot.link_id(l).expect("link").index()] * p)
            .collect();
        // Object origin at the centroid of the grasped points, axes of the hand: X = W⁻¹·O.
        let centroid = in_hand.iter().map(|p| p.coords).sum::<Vector3<f64>>() / count as f64;
        let object_in_hand =
            Isometry3::from_parts(Translation3::from(centroid), UnitQuaternion::identity());
        let contacts = |object_from_hand: &Isometry3<f64>| -> Vec<Contact> {
            picked
                .iter()
                .zip(&in_hand)
                .map(|((l, p), ph)| Contact {
                    link: l.clone(),
                    hand_point: *p,
                    object_point: object_from_hand * ph,
                })
                .collect()
        };
        // The hand in the object frame at contact frame k (in-hand motion, if any).
        let object_from_hand = |k: usize| -> Isometry3<f64> {
            let s = k as f64 / (opts.contact - 1).max(1) as f64;
            let motion = Isometry3::from_parts(
                Translation3::from(opts.in_hand_slide * s),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), opts.in_hand_turn_rad * s),
            );
            motion * object_in_hand.inverse()
        };

        let object_at = |i: usize| -> Isometry3<f64> {
            let k = i.saturating_sub(opts.pre).min(opts.contact - 1);
            let s = k as f64 / (opts.contact - 1).max(1) as f64;
            // rest 0-0.1, lift-carry-place 0.1-0.9, rest 0.9-1.
            let u = ease((s - 0.1) / 0.8);
            let lift = (std::f64::consts::PI * u).sin() * opts.lift_m;
            let pos = opts.start + opts.carry * u + Vector3::z() * lift;
            let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), opts.turn_rad * u);
            Isometry3::from_parts(Translation3::from(pos), rot)
        };
        let n = opts.pre + opts.contact + opts.post;
        let frames = (0..n)
            .map(|i| {
                let object = object_at(i);
                let k = i.saturating_sub(opts.pre).min(opts.contact - 1);
                let held = object_from_hand(k);
                let attached = object * held;
                let (wrist, joints, contacts) = if i < opts.pre {
                    // Approach along the palm normal (−x of the hand) while closing.
                    let s = ease(i as f64 / opts.pre as f64);
                    let back = attached.rotation * Vector3::new(-0.1 * (1.0 - s), 0.0, 0.0);
                    let q = blend(&open_q, &grasp_q, s);
                    (Translation3::from(back) * attached, q, Vec::new())
                } else if i < opts.pre + opts.contact {
                    (attached, grasp_q.clone(), contacts(&held))
                } else {
                    let s = ease((i + 1 - opts.pre - opts.contact) as f64 / opts.post as f64);
                    let back = attached.rotation * Vector3::new(-0.1 * s, 0.0, 0.05 * s);
                    let q = blend(&grasp_q, &open_q, s);
                    (Translation3::from(back) * attached, q, Vec::new())
                };
                Frame {
                    object,
                    wrist,
                    joints,
                    contacts,
                }
            })
            .collect();
        let demo = Demo {
            name: "synthetic_grasp".into(),
            fps: 30.0,
            robot: human_hand_path(),
            object: ObjectInfo {
                name: "cube".into(),
                mesh: mesh_path,
                mass: 0.2,
            },
            joint_names: robot.actuated_names(),
            frames,
            timewarp: None,
            scene: None,
            barriers: Vec::new(),
            wrist_link: None,
            source: dir.path().join("synthetic.demo.json"),
        };
        GraspDemo {
            demo,
            robot,
            grasp_q,
            dir,
        }
    }

    /// The object path of the demonstration.
    pub fn object_path(&self) -> ObjectPath {
        ObjectPath::from_poses(self.demo.frames.iter().map(|f| &f.object))
    }

    /// The identity warp (no waypoints), `speed` retiming so τ is the identity.
    pub fn identity_warp(&self) -> ObjectWarp {
        let input = self.object_path();
        let segment = self.demo.contact_segment().expect("contact segment");
        let plan = WarpPlan::identity(&input.positions, segment);
        warp_object(
            &input,
            &plan,
            &[],
            0.05,
            &retime_params(RetimeMode::Speed),
            Path::new("identity"),
        )
        .expect("identity warp")
    }

    /// A warp through `waypoints` (JSON, as in a config: `position`, `t`, `t_new`, optional
    /// `rotation`), no barriers.
    pub fn warp(&self, waypoints: serde_json::Value, mode: RetimeMode) -> ObjectWarp {
        self.warp_with(&config(waypoints), mode)
    }

    /// The object warp a config asks for (its waypoints, start, end; no barriers).
    pub fn warp_with(&self, cfg: &WarpConfig, mode: RetimeMode) -> ObjectWarp {
        let input = self.object_path();
        let segment = self.demo.contact_segment().expect("contact segment");
        let plan = WarpPlan::new(cfg, &input.positions, segment).expect("plan");
        warp_object(&input, &plan, &[], 0.05, &retime_params(mode), &cfg.source)
            .expect("object warp")
    }
}

/// Object-stage parameters with the given retiming rule.
pub fn retime_params(mode: RetimeMode) -> ObjectParams {
    ObjectParams::from_config(&WarpParams {
        retime: mode,
        ..WarpParams::default()
    })
}

/// A validated config with these waypoints and no barriers.
pub fn config(waypoints: serde_json::Value) -> WarpConfig {
    config_with(waypoints, serde_json::json!({}))
}

/// A validated config with these waypoints, `params` (JSON object) and no barriers.
pub fn config_with(waypoints: serde_json::Value, params: serde_json::Value) -> WarpConfig {
    let json = serde_json::json!({
        "format": "dexwarp.config/1", "name": "test", "demo": "d.demo.json",
        "scene": "s.json", "waypoints": waypoints, "barriers": [], "params": params
    });
    let file: ConfigFile = serde_json::from_value(json).expect("test config parses");
    WarpConfig::from_file(file, Path::new("test.config.json")).expect("valid config")
}

/// `(1 − s) a + s b`, element-wise.
pub fn blend(a: &[f64], b: &[f64], s: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + (y - x) * s).collect()
}
