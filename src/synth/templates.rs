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
//! | five-finger | teapot | hook through the handle loop: palm on the outer bar, index and middle middle phalanges on its inner face, thumb on top; slid in along the handle's side, in place before the fingers close, slid out level after they open, through the middle of the gap |
//! | four-finger | apple | fingertip grasp from above: three fingers on the far side, thumb on the near side |
//! | four-finger | cube | as the five-finger cube grasp |
//! | gripper | small box, cube | jaws on two opposite faces, from above |

use super::grasp::{Closing, GraspTemplate, HandFamily, PadTarget};
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
        link: tip.to_string(),
        hand_point: [r, 0.0, 0.0],
        inward: [-1.0, 0.0, 0.0],
        radius: r,
        object_point,
    }
}

fn allegro_pad(tip: &'static str, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link: tip.to_string(),
        hand_point: [ALLEGRO_PAD, 0.0, 0.0],
        inward: [-1.0, 0.0, 0.0],
        radius: ALLEGRO_PAD,
        object_point,
    }
}

/// A point on the palm side of a human phalanx: `z` [m] along the link from its joint,
/// `r` the phalanx radius [m].
fn human_phalanx(link: &'static str, r: f64, z: f64, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link: link.to_string(),
        hand_point: [r, 0.0, z],
        inward: [-1.0, 0.0, 0.0],
        radius: r,
        object_point,
    }
}

/// A palm point of the human hand: on the palm box's palm-side face (`x` = 14 mm).
fn human_palm(y: f64, z: f64, object_point: [f64; 3]) -> PadTarget {
    PadTarget {
        link: "palm".to_string(),
        hand_point: [0.014, y, z],
        inward: [-1.0, 0.0, 0.0],
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

/// The five-finger hand's grasp of `object`, if it has one.
fn human(object: ObjectKind) -> Option<GraspTemplate> {
    let t = match object {
        ObjectKind::Cube => human_cube(),
        ObjectKind::FryingPan => human_frying_pan(),
        ObjectKind::Mug => human_mug(),
        ObjectKind::Teapot => human_teapot(),
        _ => return None,
    };
    Some(t)
}

/// The four fingers of the human hand, thumb aside.
const HUMAN_FINGERS: [&str; 4] = ["index", "middle", "ring", "little"];

/// The five-finger cube grasp (see the module docs).
fn human_cube() -> GraspTemplate {
    GraspTemplate {
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
            human_open(&HUMAN_FINGERS, 0.5),
            vec![("thumb_cmc_flex", -0.3), ("thumb_cmc_abd", -0.1)],
        ]
        .concat(),
        approach: [-0.5, 0.0, 1.0],
        slide: [0.0, 0.0, 1.0],
        turn_rad: 0.25,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::WHILE_MOVING,
        level_release: false,
    }
}

/// The five-finger frying pan grasp (see the module docs).
fn human_frying_pan() -> GraspTemplate {
    GraspTemplate {
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
            human_open(&HUMAN_FINGERS, 0.9),
            vec![("thumb_mcp_flex", -0.2), ("thumb_ip_flex", -0.3)],
        ]
        .concat(),
        approach: [0.0, 0.3, 1.0],
        slide: [1.0, 0.0, 0.0],
        turn_rad: 0.25,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::WHILE_MOVING,
        level_release: false,
    }
}

/// The five-finger mug grasp (see the module docs).
fn human_mug() -> GraspTemplate {
    GraspTemplate {
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
            human_open(&HUMAN_FINGERS, 0.5),
            vec![("thumb_cmc_flex", -0.3), ("thumb_cmc_abd", -0.1)],
        ]
        .concat(),
        approach: [0.0, -0.5, 1.0],
        slide: [0.0, 0.0, 1.0],
        turn_rad: 0.25,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::WHILE_MOVING,
        level_release: false,
    }
}

/// Hook grasp through the handle loop: the palm on the outer face of the handle's
/// outer bar, index and middle through the opening with their middle phalanges on the
/// bar's inner face, the thumb on top. The hand slides in along `+y` (slightly from
/// above), with the middle finger's middle phalanx opened so it clears the bar, and without
/// the relaxed turn, which would sweep the fingers through the bar. It is in place before the
/// fingers close, and slides out level after they open: fingers closing on the move dragged
/// the pot 17.7 mm before the lift, backing off with the approach's rise lifted the
/// released pot by its handle, and sliding out straight kept the curled fingers 0.3-2.8 mm
/// from the handle and the body, which turned the released pot by 25°.
fn human_teapot() -> GraspTemplate {
    GraspTemplate {
        palm_normal: [1.0, 0.0, 0.0],
        fingers: [0.0, -1.0, 0.0],
        preshape: [
            human_finger("index", 0.9, 1.5, 0.6),
            human_finger("middle", 0.9, 1.5, 0.6),
            human_finger("ring", 0.9, 1.5, 0.6),
            human_finger("little", 0.9, 1.5, 0.6),
            vec![
                ("thumb_cmc_abd", 0.3),
                ("thumb_cmc_flex", 0.3),
                ("thumb_mcp_flex", 0.2),
                ("thumb_ip_flex", 0.2),
            ],
        ]
        .concat(),
        targets: vec![
            human_palm(0.0, 0.065, [-0.125, 0.0, 0.008]),
            human_phalanx("index_middle", 0.0085, 0.0135, [-0.099, 0.0, 0.027]),
            human_phalanx("middle_middle", 0.0085, 0.0155, [-0.099, 0.0, 0.008]),
            human_pad("thumb_tip", [-0.1, 0.0, 0.05]),
        ],
        open: vec![("middle_pip_flex", -0.5)],
        approach: [0.0, -1.0, 0.2],
        slide: [0.0, 0.0, 1.0],
        turn_rad: 0.0,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::ARRIVE_THEN_CLOSE,
        level_release: true,
    }
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
        turn_rad: 0.25,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::WHILE_MOVING,
        level_release: false,
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
                link: link.to_string(),
                hand_point: [a, 0.0, 0.045 + c],
                inward: [-1.0, 0.0, 0.0],
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
        turn_rad: 0.25,
        preshape_q: None,
        kinematic_open: false,
        closing: Closing::WHILE_MOVING,
        level_release: false,
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
