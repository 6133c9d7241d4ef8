//! Loading a [`Robot`] from URDF (urdf-rs 0.10) and checking it.
//!
//! The loader turns the URDF element lists into arenas and establishes the invariants of
//! [`super::model`]: one root, a tree (each link has at most one parent joint, no cycle),
//! joints in topological order, finite origins, unit axes, `lower ≤ upper`, mimic chains
//! resolved to actuated drivers, collision shapes built and their surfaces sampled.
//!
//! Every error names the URDF file, the element (`joint 'index_pip' <limit>`,
//! `link 'palm' collision[1]`) and what was expected. Floating, planar and spherical joints
//! are refused: dexwarp adds the floating wrist itself in front of the root link.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::{Unit, Vector3};

use super::model::{Joint, JointId, JointKind, Link, LinkId, Mimic, Robot};
use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::geometry::shape::SurfaceSampling;
use crate::limits::Limits;

impl Robot {
    /// Loads a URDF file; mesh paths resolve relative to the file's folder. Surfaces are
    /// sampled with [`SurfaceSampling::default`] (8 mm).
    ///
    /// The file size is checked against `limits.max_file_bytes` before it is read.
    pub fn from_urdf_file(path: &Path, limits: &Limits) -> Result<Robot> {
        Robot::from_urdf_file_at(path, limits, None)
    }

    /// As [`Robot::from_urdf_file`], with the floating wrist at `wrist_link` instead of the
    /// URDF root: the hand is that link's subtree, the links above it (a forearm, a mount)
    /// are dropped. An unknown link is refused with the list of links.
    pub fn from_urdf_file_at(
        path: &Path,
        limits: &Limits,
        wrist_link: Option<&str>,
    ) -> Result<Robot> {
        let bytes = limits.read_file(path, limits.max_file_bytes, "--max-file-mb")?;
        let text = String::from_utf8(bytes).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            field: "URDF".into(),
            message: format!(
                "is not UTF-8 text (invalid byte at offset {}); expected a URDF XML document",
                e.utf8_error().valid_up_to()
            ),
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Robot::from_urdf_str_at(&text, base, path, limits, wrist_link)
    }

    /// Loads a URDF document from a string. Relative mesh paths resolve against `base_dir`;
    /// `source` names the document in error messages and is stored in [`Robot::source`].
    pub fn from_urdf_str(
        text: &str,
        base_dir: &Path,
        source: &Path,
        limits: &Limits,
    ) -> Result<Robot> {
        Robot::from_urdf_str_at(text, base_dir, source, limits, None)
    }

    /// As [`Robot::from_urdf_str`], rooted at `wrist_link` (see [`Robot::from_urdf_file_at`]).
    pub fn from_urdf_str_at(
        text: &str,
        base_dir: &Path,
        source: &Path,
        limits: &Limits,
        wrist_link: Option<&str>,
    ) -> Result<Robot> {
        if text.len() as u64 > limits.max_file_bytes {
            return Err(Error::TooLarge {
                path: source.to_path_buf(),
                what: "the URDF text size in bytes",
                found: text.len() as u64,
                limit: limits.max_file_bytes,
                flag: "--max-file-mb",
            });
        }
        prescan_xml(text, source, limits)?;
        let mut urdf = urdf_rs::read_from_string(text).map_err(|e| Error::Parse {
            path: source.to_path_buf(),
            field: "URDF".into(),
            message: format!("not a valid URDF document: {e}"),
        })?;
        if let Some(link) = wrist_link {
            keep_subtree(&mut urdf, link, source)?;
        }
        Loader {
            path: source,
            base_dir,
            limits,
            mesh_cache: HashMap::new(),
        }
        .build(urdf)
    }

    /// Recomputes every link's surface points and normals with `sampling` (see
    /// [`crate::geometry::shape`] for the layout on each primitive).
    ///
    /// Where shapes of one link overlap, points buried more than
    /// [`BURIED_DEPTH`](crate::geometry::shape::BURIED_DEPTH) inside another shape of the same link are
    /// dropped: they can never touch anything.
    pub fn sample_surface_points(&mut self, sampling: &SurfaceSampling) {
        let mut points = Vec::new();
        let mut normals = Vec::new();
        for link in &mut self.links {
            link.surface_points.clear();
            link.surface_normals.clear();
            link.probes = super::probes::Probes::of_shapes(&link.collision);
            for (k, shape) in link.collision.iter().enumerate() {
                points.clear();
                normals.clear();
                shape.sample_surface(sampling, &mut points, &mut normals);
                for (p, n) in points.iter().zip(&normals) {
                    let buried = link.collision.iter().enumerate().any(|(o, other)| {
                        o != k && other.depth_of(p) > crate::geometry::shape::BURIED_DEPTH
                    });
                    if !buried {
                        link.surface_points.push(*p);
                        link.surface_normals.push(*n);
                    }
                }
            }
        }
    }
}

/// Keeps the links of `urdf` in the subtree of `link` (it included) and the joints between
/// them, so `link` becomes the root.
fn keep_subtree(urdf: &mut urdf_rs::Robot, link: &str, source: &Path) -> Result<()> {
    if !urdf.links.iter().any(|l| l.name == link) {
        let names: Vec<&str> = urdf.links.iter().map(|l| l.name.as_str()).collect();
        return Err(Error::invalid(
            source,
            "wrist_link",
            format!(
                "{link:?} is not a link of the robot; its links are: {}",
                names.join(", ")
            ),
        ));
    }
    let mut keep = std::collections::HashSet::from([link.to_string()]);
    // Joints are in any order: grow the set until it stops changing (at most one pass per
    // tree level, each linear).
    loop {
        let before = keep.len();
        for j in &urdf.joints {
            if keep.contains(&j.parent.link) {
                keep.insert(j.child.link.clone());
            }
        }
        if keep.len() == before {
            break;
        }
    }
    urdf.links.retain(|l| keep.contains(&l.name));
    urdf.joints
        .retain(|j| keep.contains(&j.parent.link) && keep.contains(&j.child.link));
    Ok(())
}

/// Counts `<link>` and `<joint>` elements and the element nesting depth of a URDF text in one
/// linear pass, without building anything, and refuses the text when a count is over
/// [`Limits::max_links`] or the depth over [`Limits::max_xml_depth`]. It runs before the XML
/// parser, whose work and recursion grow with both: 100,000 links or 20,000 levels of
/// nesting are refused in milliseconds (the depth as soon as it is passed, the counts after
/// the whole text is counted).
///
/// The scan knows just enough XML to count right: comments, CDATA sections, processing
/// instructions and declarations are skipped, `'`/`"` quoted attribute values may hold `>`,
/// and `<x/>` opens and closes at once. Malformed text is left for the parser to report.
fn prescan_xml(text: &str, source: &Path, limits: &Limits) -> Result<()> {
    let b = text.as_bytes();
    let (mut links, mut joints, mut depth, mut deepest) = (0u64, 0u64, 0u64, 0u64);
    let find = |from: usize, pat: &[u8]| {
        b.get(from..)
            .and_then(|rest| rest.windows(pat.len()).position(|w| w == pat))
            .map(|k| from + k + pat.len())
    };
    let mut i = 0;
    while let Some(k) = b
        .get(i..)
        .and_then(|rest| rest.iter().position(|&c| c == b'<'))
    {
        let at = i + k;
        let rest = &b[at..];
        let skip_to = if rest.starts_with(b"<!--") {
            find(at + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            find(at + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            find(at + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            find(at + 2, b">")
        } else {
            None
        };
        if rest.starts_with(b"<!") || rest.starts_with(b"<?") {
            match skip_to {
                Some(next) => {
                    i = next;
                    continue;
                }
                None => break,
            }
        }
        let closing = rest.get(1) == Some(&b'/');
        let name_start = at + 1 + closing as usize;
        let name_end = b[name_start..]
            .iter()
            .position(|c| c.is_ascii_whitespace() || *c == b'>' || *c == b'/')
            .map_or(b.len(), |n| name_start + n);
        // The end of the tag, past quoted attribute values.
        let mut j = name_end;
        let mut quote = None;
        while j < b.len() {
            match (quote, b[j]) {
                (None, b'"' | b'\'') => quote = Some(b[j]),
                (Some(q), c) if c == q => quote = None,
                (None, b'>') => break,
                _ => {}
            }
            j += 1;
        }
        if j >= b.len() {
            break;
        }
        let self_closing = b[j - 1] == b'/';
        if closing {
            depth = depth.saturating_sub(1);
        } else {
            match &b[name_start..name_end] {
                b"link" => links += 1,
                b"joint" => joints += 1,
                _ => {}
            }
            if !self_closing {
                depth += 1;
                deepest = deepest.max(depth);
            }
        }
        if deepest > limits.max_xml_depth {
            return Err(Error::TooLarge {
                path: source.to_path_buf(),
                what: "the XML element nesting depth",
                found: deepest,
                limit: limits.max_xml_depth,
                flag: "--max-xml-depth",
            });
        }
        i = j + 1;
    }
    // Counting to the end is linear and cheap; the message then gives the true count.
    for (what, found) in [
        ("the number of <link> elements", links),
        ("the number of <joint> elements", joints),
    ] {
        if found > limits.max_links {
            return Err(Error::TooLarge {
                path: source.to_path_buf(),
                what,
                found,
                limit: limits.max_links,
                flag: "--max-links",
            });
        }
    }
    Ok(())
}

/// State of one load: where messages point and meshes already read.
pub(super) struct Loader<'a> {
    /// The URDF file, named in every error.
    pub(super) path: &'a Path,
    /// Folder that relative mesh paths start from.
    pub(super) base_dir: &'a Path,
    pub(super) limits: &'a Limits,
    /// Meshes by resolved path, unscaled: a mesh used by several links is read once.
    pub(super) mesh_cache: HashMap<PathBuf, Arc<Mesh>>,
}

/// The kinematic tree as read from URDF, indices in URDF order.
struct Tree {
    /// URDF joint index by name.
    joint_index: HashMap<String, usize>,
    /// `(parent link, child link)` of each URDF joint.
    ends: Vec<(usize, usize)>,
    /// URDF joint index whose child each link is.
    parent_of: Vec<Option<usize>>,
    /// The root link.
    root: usize,
}

impl Loader<'_> {
    /// An [`Error::Invalid`] for this URDF file.
    pub(super) fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> Error {
        Error::invalid(self.path, field, message)
    }

    /// The loader's stages, in order; each returns the first problem it finds.
    fn build(mut self, urdf: urdf_rs::Robot) -> Result<Robot> {
        self.check_sizes(&urdf)?;
        let tree = self.tree(&urdf)?;
        let order = self.topological_order(&urdf, &tree)?;
        // new_id[urdf index] = JointId (position in topological order).
        let mut new_id = vec![0; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_id[old] = new;
        }
        let mut joints = order
            .iter()
            .map(|&old| self.joint(&urdf.joints[old], tree.ends[old]))
            .collect::<Result<Vec<_>>>()?;
        let (actuated, lower, upper) = assign_dofs(&urdf, &new_id, &mut joints);
        self.resolve_mimics(&urdf, &tree, &new_id, &mut joints)?;
        let links = self.links(&urdf, &tree, &new_id)?;
        let chains = chains(&joints, links.len());
        let mut robot = Robot {
            name: urdf.name,
            source: self.path.to_path_buf(),
            links,
            joints,
            root: LinkId(tree.root as u32),
            actuated,
            chains,
            lower,
            upper,
        };
        robot.sample_surface_points(&SurfaceSampling::default());
        Ok(robot)
    }

    /// Refuses robots over `limits.max_links` links or joints, and robots without links.
    fn check_sizes(&self, urdf: &urdf_rs::Robot) -> Result<()> {
        for (what, n) in [
            ("the number of links", urdf.links.len()),
            ("the number of joints", urdf.joints.len()),
        ] {
            if n as u64 > self.limits.max_links {
                return Err(Error::TooLarge {
                    path: self.path.to_path_buf(),
                    what,
                    found: n as u64,
                    limit: self.limits.max_links,
                    flag: "--max-links",
                });
            }
        }
        if urdf.links.is_empty() {
            return Err(self.invalid("robot", "the URDF has no <link>; expected at least one"));
        }
        Ok(())
    }

    /// Names are unique, joint types supported, joint ends known and distinct, every link
    /// the child of at most one joint, and exactly one link (the root) the child of none.
    fn tree(&self, urdf: &urdf_rs::Robot) -> Result<Tree> {
        let mut link_index: HashMap<&str, usize> = HashMap::new();
        for (i, l) in urdf.links.iter().enumerate() {
            if link_index.insert(l.name.as_str(), i).is_some() {
                return Err(self.invalid(
                    format!("link '{}'", l.name),
                    "two links have this name; link names must be unique",
                ));
            }
        }
        let mut joint_index = HashMap::new();
        let mut parent_of: Vec<Option<usize>> = vec![None; urdf.links.len()];
        let mut ends = Vec::with_capacity(urdf.joints.len());
        for (i, j) in urdf.joints.iter().enumerate() {
            let field = format!("joint '{}'", j.name);
            if joint_index.insert(j.name.clone(), i).is_some() {
                return Err(self.invalid(
                    field,
                    "two joints have this name; joint names must be unique",
                ));
            }
            kind_of(j).map_err(|t| {
                Error::unsupported(
                    self.path,
                    &field,
                    format!(
                        "type=\"{t}\" is not supported inside the hand; dexwarp adds the floating \
                         wrist itself, so make the root the palm and use fixed, revolute, \
                         continuous or prismatic joints"
                    ),
                )
            })?;
            let find = |role: &str, name: &str| {
                link_index.get(name).copied().ok_or_else(|| {
                    self.invalid(
                        format!("{field} <{role} link=\"{name}\">"),
                        format!("no link is named '{name}'; expected one of the <link> names"),
                    )
                })
            };
            let parent = find("parent", &j.parent.link)?;
            let child = find("child", &j.child.link)?;
            if parent == child {
                return Err(self.invalid(
                    field,
                    format!("parent and child are the same link '{}'", j.child.link),
                ));
            }
            if let Some(other) = parent_of[child] {
                return Err(self.invalid(
                    field,
                    format!(
                        "link '{}' is already the child of joint '{}'; a link has at most one \
                         parent joint (the URDF must be a tree)",
                        j.child.link, urdf.joints[other].name
                    ),
                ));
            }
            parent_of[child] = Some(i);
            ends.push((parent, child));
        }
        let roots: Vec<usize> = (0..urdf.links.len())
            .filter(|&l| parent_of[l].is_none())
            .collect();
        let root = match roots.as_slice() {
            [r] => *r,
            [] => {
                return Err(self.invalid(
                    "robot",
                    "every link has a parent joint, so the joints form a cycle; expected one \
                     root link (the palm)",
                ));
            }
            many => {
                let names: Vec<String> = many
                    .iter()
                    .map(|&l| format!("'{}'", urdf.links[l].name))
                    .collect();
                return Err(self.invalid(
                    "robot",
                    format!(
                        "more than one root link ({}); expected a single tree: connect the \
                         extra links with fixed joints or remove them",
                        names.join(", ")
                    ),
                ));
            }
        };
        Ok(Tree {
            joint_index,
            ends,
            parent_of,
            root,
        })
    }

    /// URDF joint indices in an order where every joint's parent link is the root or the
    /// child of an earlier joint; ties keep the URDF order. With one parent per link and one
    /// root, joints that can never be placed form a cycle detached from the root.
    fn topological_order(&self, urdf: &urdf_rs::Robot, tree: &Tree) -> Result<Vec<usize>> {
        let n = tree.ends.len();
        let mut placed = vec![false; urdf.links.len()];
        placed[tree.root] = true;
        let mut done = vec![false; n];
        let mut order = Vec::with_capacity(n);
        while order.len() < n {
            let before = order.len();
            for (i, &(parent, child)) in tree.ends.iter().enumerate() {
                if !done[i] && placed[parent] {
                    done[i] = true;
                    placed[child] = true;
                    order.push(i);
                }
            }
            if order.len() == before {
                let cycle: Vec<String> = (0..n)
                    .filter(|&i| !done[i])
                    .map(|i| format!("'{}'", urdf.joints[i].name))
                    .collect();
                return Err(self.invalid(
                    "robot",
                    format!(
                        "the joints {} form a cycle not connected to root link '{}'; expected a tree",
                        cycle.join(", "),
                        urdf.links[tree.root].name
                    ),
                ));
            }
        }
        Ok(order)
    }

    /// One joint: origin finite, axis finite and non-zero for movable joints (normalised),
    /// limits not NaN with `lower ≤ upper` for revolute and prismatic joints. URDF files
    /// before 1.2 without `<limit>` read as `[0, 0]` (a locked joint, accepted).
    fn joint(&self, j: &urdf_rs::Joint, (parent, child): (usize, usize)) -> Result<Joint> {
        let field = format!("joint '{}'", j.name);
        let kind = kind_of(j).expect("checked by tree()");
        let origin = self.pose(&j.origin, &field)?;
        let axis = if kind.is_movable() {
            let a = Vector3::from(j.axis.xyz.0);
            if !a.iter().all(|c| c.is_finite()) {
                return Err(self.invalid(
                    format!("{field} <axis>"),
                    format!(
                        "xyz {:?} is not finite; expected a unit vector",
                        j.axis.xyz.0
                    ),
                ));
            }
            Unit::try_new(a, 1e-9).ok_or_else(|| {
                self.invalid(
                    format!("{field} <axis>"),
                    "xyz is the zero vector; expected a non-zero axis such as \"0 0 1\"",
                )
            })?
        } else {
            Vector3::x_axis()
        };
        let limits = match kind {
            JointKind::Revolute | JointKind::Prismatic => {
                let (lo, hi) = (j.limit.lower, j.limit.upper);
                if lo.is_nan() || hi.is_nan() {
                    return Err(self.invalid(
                        format!("{field} <limit>"),
                        "lower or upper is NaN; expected numbers",
                    ));
                }
                if lo > hi {
                    return Err(self.invalid(
                        format!("{field} <limit>"),
                        format!("lower {lo} is greater than upper {hi}; expected lower <= upper"),
                    ));
                }
                Some((lo, hi))
            }
            _ => None,
        };
        let effort = if kind.is_movable() {
            j.limit.effort
        } else {
            0.0
        };
        if !(effort.is_finite() && effort >= 0.0) {
            return Err(self.invalid(
                format!("{field} <limit>"),
                format!("effort {effort} is not a finite value >= 0"),
            ));
        }
        Ok(Joint {
            name: j.name.clone(),
            kind,
            parent: LinkId(parent as u32),
            child: LinkId(child as u32),
            origin,
            axis,
            limits,
            mimic: None,
            dof: None,
            mimic_source: j.mimic.as_ref().map(|m| m.joint.clone()),
            effort,
        })
    }

    /// Resolves each `<mimic>` to its ultimate actuated driver. Along a chain
    /// `θ = m₁ θ₁ + c₁`, `θ₁ = m₂ θ₂ + c₂`, … the maps compose as
    /// `θ = (m₁ m₂) θ₂ + (m₁ c₂ + c₁)`. Refuses a mimic on a fixed joint, of an unknown or
    /// fixed joint, non-finite coefficients, and cycles (a chain longer than the joint count).
    fn resolve_mimics(
        &self,
        urdf: &urdf_rs::Robot,
        tree: &Tree,
        new_id: &[usize],
        joints: &mut [Joint],
    ) -> Result<()> {
        for (old, j) in urdf.joints.iter().enumerate() {
            let Some(m) = &j.mimic else { continue };
            let field = format!("joint '{}' <mimic joint=\"{}\">", j.name, m.joint);
            if !joints[new_id[old]].kind.is_movable() {
                return Err(self.invalid(
                    field,
                    "a fixed joint cannot mimic another joint; remove <mimic> or make the joint movable",
                ));
            }
            let (mut mult, mut off) = (m.multiplier.unwrap_or(1.0), m.offset.unwrap_or(0.0));
            let mut target = m.joint.as_str();
            let mut hops = 0;
            let driver = loop {
                if !mult.is_finite() || !off.is_finite() {
                    return Err(self.invalid(field, "multiplier and offset must be finite numbers"));
                }
                let Some(&t) = tree.joint_index.get(target) else {
                    return Err(self.invalid(
                        field,
                        format!(
                            "no joint is named '{target}'; expected the name of a movable joint"
                        ),
                    ));
                };
                let tj = &joints[new_id[t]];
                if !tj.kind.is_movable() {
                    return Err(self.invalid(
                        field,
                        format!("joint '{target}' is fixed and cannot drive a mimic joint"),
                    ));
                }
                if let Some(d) = tj.dof {
                    break d;
                }
                hops += 1;
                if hops > urdf.joints.len() {
                    return Err(self.invalid(
                        field,
                        "the mimic relations form a cycle; expected every mimic chain to end at a \
                         joint without <mimic>",
                    ));
                }
                let next = urdf.joints[t]
                    .mimic
                    .as_ref()
                    .expect("movable non-actuated joint");
                let (m2, c2) = (next.multiplier.unwrap_or(1.0), next.offset.unwrap_or(0.0));
                off += mult * c2;
                mult *= m2;
                target = next.joint.as_str();
            };
            joints[new_id[old]].mimic = Some(Mimic {
                driver,
                multiplier: mult,
                offset: off,
            });
        }
        Ok(())
    }

    /// Links with their collision shapes (surface points are sampled afterwards).
    fn links(&mut self, urdf: &urdf_rs::Robot, tree: &Tree, new_id: &[usize]) -> Result<Vec<Link>> {
        let mut links = Vec::with_capacity(urdf.links.len());
        for (i, l) in urdf.links.iter().enumerate() {
            let mass = l.inertial.mass.value;
            if !(mass.is_finite() && mass >= 0.0) {
                return Err(self.invalid(
                    format!("link '{}' <inertial><mass>", l.name),
                    format!("value {mass} is not a finite mass >= 0 [kg]"),
                ));
            }
            let mut collision = Vec::with_capacity(l.collision.len());
            for (k, c) in l.collision.iter().enumerate() {
                let field = format!("link '{}' collision[{k}]", l.name);
                collision.push(self.collision(c, &field)?);
            }
            links.push(Link {
                name: l.name.clone(),
                parent_joint: tree.parent_of[i].map(|j| JointId(new_id[j] as u32)),
                collision,
                surface_points: Vec::new(),
                surface_normals: Vec::new(),
                probes: Default::default(),
                mass,
            });
        }
        Ok(links)
    }
}

/// Numbers the actuated joints (movable, not mimic) in URDF declaration order, which is
/// the order users see in `q` and in demo `joint_names`; returns them with their limits
/// (`±inf` for continuous joints).
fn assign_dofs(
    urdf: &urdf_rs::Robot,
    new_id: &[usize],
    joints: &mut [Joint],
) -> (Vec<JointId>, Vec<f64>, Vec<f64>) {
    let mut actuated = Vec::new();
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    for (old, j) in urdf.joints.iter().enumerate() {
        let joint = &mut joints[new_id[old]];
        if joint.kind.is_movable() && j.mimic.is_none() {
            joint.dof = Some(actuated.len());
            actuated.push(JointId(new_id[old] as u32));
            let (lo, hi) = joint.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            lower.push(lo);
            upper.push(hi);
        }
    }
    (actuated, lower, upper)
}

/// Per link, the movable joints from the root to the link, root first. One pass in
/// topological order: a child's chain is its parent's plus its own joint when movable.
fn chains(joints: &[Joint], link_count: usize) -> Vec<Box<[JointId]>> {
    let mut chains: Vec<Vec<JointId>> = vec![Vec::new(); link_count];
    for (id, joint) in joints.iter().enumerate() {
        let mut chain = chains[joint.parent.index()].clone();
        if joint.kind.is_movable() {
            chain.push(JointId(id as u32));
        }
        chains[joint.child.index()] = chain;
    }
    chains.into_iter().map(Vec::into_boxed_slice).collect()
}

/// The joint kind, or the URDF type name when it is not supported inside the tree.
fn kind_of(j: &urdf_rs::Joint) -> std::result::Result<JointKind, &'static str> {
    match j.joint_type {
        urdf_rs::JointType::Fixed => Ok(JointKind::Fixed),
        urdf_rs::JointType::Revolute => Ok(JointKind::Revolute),
        urdf_rs::JointType::Continuous => Ok(JointKind::Continuous),
        urdf_rs::JointType::Prismatic => Ok(JointKind::Prismatic),
        urdf_rs::JointType::Floating => Err("floating"),
        urdf_rs::JointType::Planar => Err("planar"),
        urdf_rs::JointType::Spherical => Err("spherical"),
    }
}
