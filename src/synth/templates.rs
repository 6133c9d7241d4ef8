//! The grasps synthesis knows: where each hand family puts its pads on each object.
//!
//! Object frames are those of [`super::objects`] (origin at the main body's centroid, `z` up;
//! pan and mug handles along `+x`, the teapot handle along `−x`). Hand frames follow
//! `robots/README.md`: `+x` the palm normal, `+z` toward the fingers, `+y` toward the thumb;
//! every `<finger>_tip` frame is the centre of the pad's hemisphere, the pad facing `+x`.
//!
//! | hand | object | grasp |
//! |---|---|---|
//! | five-finger | cube | from above: thumb on the near face, index and middle on the far face |
//! | five-finger | frying pan | power grasp of the handle: palm on top, fingers wrapped under, thumb along the top toward the pan |
//! | five-finger | mug | body from above: thumb on the near side, index, middle and ring on the far side, clear of the handle |
//! | five-finger | teapot | hook grasp of the handle: proximal phalanges across the outer bar, middle phalanges and pads flat on one side, thumb pad on top |
//! | four-finger | apple | fingertip grasp from above: three fingers on the far side, thumb on the near side |
//! | four-finger | cube | as the five-finger cube grasp |
//! | gripper | small box, cube | jaws on two opposite faces, from above |

use super::grasp::{GraspTemplate, HandFamily, PadTarget};
use super::objects::ObjectKind;

/// Pad radii [m] (`robots/README.md`).
const HUMAN_PAD: [(&str, f64); 5] = [
    ("thumb_tip", 0.0088),
    ("index_tip", 0.0075),
    ("middle_tip", 0.0075),
    ("ring_tip", 0.0072),
    ("little_tip", 0.0068),
];
const ALLEGRO_PAD: f64 = 0.014;

fn human_pad(tip: &'static str, object_point: [f64; 3]) -> PadTarget {
    let r = HUMAN_PAD
        .iter()
        .find(|(n, _)| *n == tip)
        .map_or(0.0075, |(_, r)| *r);
    PadTarget {
        link: tip,
        hand_point: [r, 0.0, 0.0],
        radius: r,
        object_point,
    }
}

fn allegro_pad(tip: &'static str, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link: tip,
        hand_point: [ALLEGRO_PAD, 0.0, 0.0],
        radius: ALLEGRO_PAD,
        object_point,
    }
}

/// A point of a phalanx of the human hand: on the palm-side surface of its capsule
/// (radius `r`) at `z` along the link.
fn human_phalanx(link: &'static str, r: f64, z: f64, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link,
        hand_point: [r, 0.0, z],
        radius: r,
        object_point,
    }
}

/// A palm point of the human hand: on the palm box's palm-side face (`x` = 14 mm).
fn human_palm(y: f64, z: f64, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link: "palm",
        hand_point: [0.014, y, z],
        radius: 0.0,
        object_point,
    }
}

/// Flexion offsets opening every finger of the human hand.
fn human_open(fingers: &[&'static str], amount: f64) -> Vec<(&'static str, f64)> {
    let mut out = Vec::new();
    for f in fingers {
        let (mcp, pip, dip): (&'static str, &'static str, &'static str) = match *f {
            "index" => ("index_mcp_flex", "index_pip_flex", "index_dip_flex"),
            "middle" => ("middle_mcp_flex", "middle_pip_flex", "middle_dip_flex"),
            "ring" => ("ring_mcp_flex", "ring_pip_flex", "ring_dip_flex"),
            "little" => ("little_mcp_flex", "little_pip_flex", "little_dip_flex"),
            _ => continue,
        };
        out.push((mcp, -0.5 * amount));
        out.push((pip, -amount));
        out.push((dip, -0.6 * amount));
    }
    out
}

/// A curled human finger: `(mcp, pip, dip)` flexion.
fn human_finger(f: &'static str, mcp: f64, pip: f64, dip: f64) -> Vec<(&'static str, f64)> {
    let names: [&'static str; 3] = match f {
        "index" => ["index_mcp_flex", "index_pip_flex", "index_dip_flex"],
        "middle" => ["middle_mcp_flex", "middle_pip_flex", "middle_dip_flex"],
        "ring" => ["ring_mcp_flex", "ring_pip_flex", "ring_dip_flex"],
        _ => ["little_mcp_flex", "little_pip_flex", "little_dip_flex"],
    };
    vec![(names[0], mcp), (names[1], pip), (names[2], dip)]
}

fn human(object: ObjectKind) -> Option<GraspTemplate> {
    let all = ["index", "middle", "ring", "little"];
    let t = match object {
        ObjectKind::Cube => GraspTemplate {
            palm_normal: [0.0, 0.0, -1.0],
            fingers: [1.0, 0.0, 0.0],
            preshape: [
                human_finger("index", 0.8, 0.7, 0.4),
                human_finger("middle", 0.8, 0.7, 0.4),
                human_finger("ring", 0.6, 0.6, 0.3),
                human_finger("little", 0.6, 0.6, 0.3),
                vec![
                    ("thumb_cmc_abd", 0.6),
                    ("thumb_cmc_flex", 0.3),
                    ("thumb_mcp_flex", 0.2),
                    ("thumb_ip_flex", 0.2),
                ],
            ]
            .concat(),
            targets: vec![
                human_pad("thumb_tip", [-0.04, 0.0, 0.01]),
                human_pad("index_tip", [0.04, 0.013, 0.01]),
                human_pad("middle_tip", [0.04, -0.011, 0.008]),
            ],
            open: [
                human_open(&all, 0.5),
                vec![("thumb_cmc_flex", -0.3), ("thumb_cmc_abd", -0.1)],
            ]
            .concat(),
            approach: [-0.5, 0.0, 1.0],
            slide: [0.0, 0.0, 1.0],
        },
        ObjectKind::FryingPan => GraspTemplate {
            palm_normal: [0.0, 0.0, -1.0],
            fingers: [0.0, 1.0, 0.0],
            preshape: [
                human_finger("index", 1.0, 1.3, 0.6),
                human_finger("middle", 1.0, 1.3, 0.6),
                human_finger("ring", 1.0, 1.3, 0.6),
                human_finger("little", 1.0, 1.3, 0.6),
                vec![("thumb_cmc_abd", 0.2), ("thumb_cmc_flex", 0.2)],
            ]
            .concat(),
            targets: vec![
                human_palm(0.0, 0.065, [0.245, 0.0, 0.08]),
                human_pad("thumb_tip", [0.175, 0.0, 0.08]),
                human_pad("index_tip", [0.205, -0.004, -0.02]),
                human_pad("middle_tip", [0.228, -0.004, -0.02]),
                human_pad("ring_tip", [0.25, -0.004, -0.02]),
                human_pad("little_tip", [0.27, -0.004, -0.02]),
            ],
            open: [
                human_open(&all, 0.9),
                vec![("thumb_mcp_flex", -0.2), ("thumb_ip_flex", -0.3)],
            ]
            .concat(),
            approach: [0.0, 0.3, 1.0],
            slide: [1.0, 0.0, 0.0],
        },
        ObjectKind::Mug => GraspTemplate {
            palm_normal: [0.0, 0.0, -1.0],
            fingers: [0.0, 1.0, 0.0],
            preshape: [
                human_finger("index", 0.8, 0.7, 0.4),
                human_finger("middle", 0.8, 0.7, 0.4),
                human_finger("ring", 0.8, 0.7, 0.4),
                human_finger("little", 1.3, 1.4, 0.9),
                vec![
                    ("thumb_cmc_abd", 0.6),
                    ("thumb_cmc_flex", 0.3),
                    ("thumb_mcp_flex", 0.2),
                    ("thumb_ip_flex", 0.2),
                ],
            ]
            .concat(),
            targets: vec![
                human_pad("thumb_tip", [0.0, -0.05, 0.032]),
                human_pad("index_tip", [-0.015, 0.05, 0.034]),
                human_pad("middle_tip", [0.01, 0.05, 0.03]),
                human_pad("ring_tip", [0.03, 0.04, 0.026]),
            ],
            open: [
                human_open(&all, 0.5),
                vec![("thumb_cmc_flex", -0.3), ("thumb_cmc_abd", -0.1)],
            ]
            .concat(),
            approach: [0.0, -0.5, 1.0],
            slide: [0.0, 0.0, 1.0],
        },
        // Hook grasp of the handle (`x` from -119 mm at the outer bar to -75 mm at the body,
        // `|y|` <= 9 mm, `z` from -29 to 41 mm): the hand behind the handle, palm toward the
        // pot, thumb up; the proximal phalanges across the outer bar, the middle phalanges
        // and pads flat on its -y face, the thumb pad on top of the handle.
        ObjectKind::Teapot => GraspTemplate {
            palm_normal: [1.0, 0.0, 0.0],
            fingers: [0.0, -1.0, 0.0],
            preshape: [
                human_finger("index", 0.2, 1.5, 0.3),
                human_finger("middle", 0.2, 1.5, 0.3),
                human_finger("ring", 0.2, 1.5, 0.3),
                human_finger("little", 0.3, 1.5, 0.5),
                vec![
                    ("thumb_cmc_abd", 0.6),
                    ("thumb_cmc_flex", 0.3),
                    ("thumb_mcp_flex", 0.2),
                    ("thumb_ip_flex", 0.2),
                ],
            ]
            .concat(),
            targets: vec![
                human_phalanx("index_proximal", 0.0095, 0.035, [-0.115, 0.0, 0.026]),
                human_phalanx("middle_proximal", 0.0095, 0.038, [-0.12, 0.0, 0.006]),
                human_phalanx("ring_proximal", 0.009, 0.036, [-0.118, 0.0, -0.014]),
                human_phalanx("index_middle", 0.0085, 0.0135, [-0.114, -0.009, 0.026]),
                human_phalanx("middle_middle", 0.0085, 0.0155, [-0.114, -0.009, 0.006]),
                human_phalanx("ring_middle", 0.008, 0.015, [-0.114, -0.009, -0.014]),
                human_pad("index_tip", [-0.092, -0.009, 0.026]),
                human_pad("middle_tip", [-0.092, -0.009, 0.006]),
                human_pad("ring_tip", [-0.092, -0.009, -0.014]),
                human_pad("thumb_tip", [-0.092, 0.0, 0.045]),
            ],
            open: [
                human_open(&["index", "middle", "ring"], 0.9),
                human_open(&["little"], 0.4),
                vec![("thumb_cmc_flex", -0.3), ("thumb_cmc_abd", -0.1)],
            ]
            .concat(),
            approach: [-1.0, 0.0, 0.4],
            slide: [0.0, 0.0, 1.0],
        },
        _ => return None,
    };
    Some(t)
}

fn allegro(object: ObjectKind) -> Option<GraspTemplate> {
    let curl = |f: &'static str, a: f64, b: f64, c: f64| -> Vec<(&'static str, f64)> {
        let names: [&'static str; 3] = match f {
            "index" => ["index_joint_1", "index_joint_2", "index_joint_3"],
            "middle" => ["middle_joint_1", "middle_joint_2", "middle_joint_3"],
            _ => ["ring_joint_1", "ring_joint_2", "ring_joint_3"],
        };
        vec![(names[0], a), (names[1], b), (names[2], c)]
    };
    let preshape = [
        curl("index", 0.9, 0.6, 0.4),
        curl("middle", 0.9, 0.6, 0.4),
        curl("ring", 0.9, 0.6, 0.4),
        vec![
            ("thumb_joint_0", 1.2),
            ("thumb_joint_1", 0.4),
            ("thumb_joint_2", 0.4),
            ("thumb_joint_3", 0.3),
        ],
    ]
    .concat();
    let open = [
        curl("index", -0.4, -0.3, -0.2),
        curl("middle", -0.4, -0.3, -0.2),
        curl("ring", -0.4, -0.3, -0.2),
        vec![("thumb_joint_1", -0.3), ("thumb_joint_2", -0.3)],
    ]
    .concat();
    let (targets, approach) = match object {
        ObjectKind::Apple => (
            vec![
                allegro_pad("index_tip", [0.035, 0.03, 0.012]),
                allegro_pad("middle_tip", [0.045, 0.0, 0.012]),
                allegro_pad("ring_tip", [0.035, -0.03, 0.012]),
                allegro_pad("thumb_tip", [-0.045, 0.01, 0.012]),
            ],
            [-0.4, 0.0, 1.0],
        ),
        ObjectKind::Cube => (
            vec![
                allegro_pad("index_tip", [0.04, 0.018, 0.01]),
                allegro_pad("middle_tip", [0.04, -0.005, 0.01]),
                allegro_pad("thumb_tip", [-0.04, 0.005, 0.01]),
            ],
            [-0.4, 0.0, 1.0],
        ),
        _ => return None,
    };
    Some(GraspTemplate {
        palm_normal: [0.0, 0.0, -1.0],
        fingers: [1.0, 0.0, 0.0],
        preshape,
        targets,
        open,
        approach,
        // Fingertips on a round object: no free direction; the drift is kept small.
        slide: [0.0, 0.0, 1.0],
    })
}

fn gripper(object: ObjectKind) -> Option<GraspTemplate> {
    let half = match object {
        ObjectKind::SmallBox => 0.02,
        ObjectKind::Cube => 0.03,
        _ => return None,
    };
    // Gripper frame: +z approach (down, object -z), jaws along ±y (object ±y), +x = y × z
    // (object -x). A pad point (a, 0, 45 mm + c) of a jaw lands on (-a, ±half, z0 - c).
    let z0 = 0.008;
    let mut targets = Vec::new();
    for (a, c) in [
        (0.0, 0.0),
        (0.006, 0.006),
        (-0.006, 0.006),
        (0.006, -0.006),
        (-0.006, -0.006),
    ] {
        for (link, side) in [("left_finger", 1.0), ("right_finger", -1.0)] {
            targets.push(PadTarget {
                link,
                hand_point: [a, 0.0, 0.045 + c],
                radius: 0.0,
                object_point: [-a, side * (half + 0.01), z0 - c],
            });
        }
    }
    Some(GraspTemplate {
        palm_normal: [-1.0, 0.0, 0.0],
        fingers: [0.0, 0.0, -1.0],
        preshape: vec![("finger_joint1", half)],
        targets,
        open: vec![("finger_joint1", 0.012)],
        approach: [0.0, 0.0, 1.0],
        slide: [0.0, 0.0, 1.0],
    })
}

/// The grasp of `object` by a hand of `family`, if synthesis knows one.
pub fn template(family: HandFamily, object: ObjectKind) -> Option<GraspTemplate> {
    match family {
        HandFamily::Human => human(object),
        HandFamily::Allegro => allegro(object),
        HandFamily::Gripper => gripper(object),
    }
}

/// The objects a hand of `family` has a grasp for.
pub fn objects_for(family: HandFamily) -> Vec<ObjectKind> {
    ObjectKind::ALL
        .into_iter()
        .filter(|o| template(family, *o).is_some())
        .collect()
}

#[cfg(test)]
mod scratch {
    use super::*;
    use crate::robot::{CollisionShape, Robot, ShapeKind};
    use crate::synth::grasp::*;
    use crate::synth::proximity::{ObjectGeometry, penetration};
    use nalgebra::{Isometry3, Vector3};

    #[test]
    #[ignore = "scratch"]
    fn teapot_try() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let robot =
            Robot::from_urdf_file(&root.join("robots/human_hand.urdf"), &crate::Limits::default())
                .unwrap();
        let mut t = template(HandFamily::Human, ObjectKind::Teapot).unwrap();
        // override from /tmp/exp/t.json: {"targets": [[link, hx,hy,hz, r, ox,oy,oz]], "preshape": [[name, v]]}
        if let Ok(txt) = std::fs::read_to_string("/tmp/exp/t.json") {
            let v: serde_json::Value = serde_json::from_str(&txt).unwrap();
            if let Some(ts) = v.get("targets") {
                t.targets = ts
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|e| {
                        let a = e.as_array().unwrap();
                        let f = |i: usize| a[i].as_f64().unwrap();
                        PadTarget {
                            link: Box::leak(a[0].as_str().unwrap().to_string().into_boxed_str()),
                            hand_point: [f(1), f(2), f(3)],
                            radius: f(4),
                            object_point: [f(5), f(6), f(7)],
                        }
                    })
                    .collect();
            }
            if let Some(ps) = v.get("preshape") {
                t.preshape = ps
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|e| {
                        let a = e.as_array().unwrap();
                        (
                            &*Box::leak(a[0].as_str().unwrap().to_string().into_boxed_str()),
                            a[1].as_f64().unwrap(),
                        )
                    })
                    .collect();
            }
            if let Some(ps) = v.get("palm_normal") {
                let a: Vec<f64> = serde_json::from_value(ps.clone()).unwrap();
                t.palm_normal = [a[0], a[1], a[2]];
            }
            if let Some(ps) = v.get("fingers") {
                let a: Vec<f64> = serde_json::from_value(ps.clone()).unwrap();
                t.fingers = [a[0], a[1], a[2]];
            }
        }
        let mesh = ObjectKind::Teapot.mesh();
        let geo = ObjectGeometry::new(mesh.clone()).unwrap();
        let shape = CollisionShape::new(
            ShapeKind::Mesh {
                path: "x.obj".into(),
                scale: Vector3::repeat(1.0),
                mesh: std::sync::Arc::new(mesh),
            },
            Isometry3::identity(),
        )
        .unwrap();
        let pose = Isometry3::translation(0.0, 0.0, 0.9 - geo.min_z);
        let table = CollisionShape::new(
            ShapeKind::Box {
                size: Vector3::new(2.0, 2.0, 0.2),
            },
            Isometry3::translation(0.0, 0.0, 0.8),
        )
        .unwrap();
        let params = GraspParams {
            accept_mm: 100.0,
            max_depth_mm: 100.0,
            ..GraspParams::default()
        };
        let g = solve(&robot, &t, &geo, &shape, &pose, std::slice::from_ref(&table), &params)
            .unwrap();
        println!("ik {:.2} mm, depth {:.2}", g.ik_mean_mm, g.depth_mm);
        let mut poses = robot.new_link_poses();
        let w = pose * g.wrist_in_object;
        robot.forward_kinematics(&w, &g.q, &mut poses);
        let targets = resolve_targets(&robot, &t, &geo).unwrap();
        for c in &targets {
            let hp = pose.inverse() * (poses[c.link.index()] * c.hand_point);
            println!(
                "{:16} hand {:?} -> obj {:?}: {:.1} mm (at {:.4?})",
                robot.link(c.link).name,
                c.hand_point.coords.as_slice(),
                c.object_point.coords.as_slice(),
                (hp - c.object_point).norm() * 1e3,
                hp.coords.as_slice()
            );
        }
        let pen = penetration(&robot, &poses, &geo, &pose);
        println!("pen {:.2} mm at {:?}", pen.depth_m * 1e3, pen.link.map(|l| robot.link(l).name.clone()));
        let samples = crate::synth::contacts::hand_samples(&robot, 0.005);
        let c = crate::synth::contacts::extract(&robot, &samples, &poses, &geo, &pose, 0.006);
        let mut per: std::collections::BTreeMap<String, usize> = Default::default();
        for x in &c {
            *per.entry(x.link.clone()).or_default() += 1;
        }
        println!("{} contacts {per:?}", c.len());
        println!("wrist {:?}", g.wrist_in_object);
        for (n, v) in robot.actuated_names().iter().zip(&g.q) {
            print!("{n}={v:.2} ");
        }
        println!();
    }
}
