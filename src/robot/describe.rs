//! The text printed by `dexwarp robot URDF` (`impl Display for Robot`).
//!
//! Three parts, made for a reader checking a hand before using it:
//! 1. a summary: name and file, counts of links and of each joint type, the DoF (the 6 of
//!    the floating wrist that dexwarp adds, plus the actuated joints), the root link and the
//!    number of surface points;
//! 2. the joint table in tree order: the index in `q` (`-` for fixed and mimic joints),
//!    name, type, `parent -> child`, limits in rad or m, and the mimic relation resolved to
//!    its driver (`= 0.4 * j1 - 0.15 (via 'j2')` when declared through another mimic);
//! 3. per link: its collision shapes with dimensions in millimetres and their origin
//!    (`xyz` in mm, `rpy` in degrees, omitted when identity), and its surface points.
//!
//! Columns are sized to their content so that the table stays aligned for any name length.

use std::fmt::{self, Display};

use nalgebra::Isometry3;

use super::model::{JointKind, Robot};
use crate::geometry::shape::CollisionShape;

/// Formats a limit: `-0.350`, or `-inf`/`inf` for an unbounded side.
fn limit(v: f64) -> String {
    if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{v:.3}")
    }
}

/// A coefficient with at most 6 decimals and no trailing zeros: `0.4`, `-0.15`, `2`.
fn coef(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// `xyz (..) mm rpy (..) deg`, or the empty string for the identity.
fn pose(p: &Isometry3<f64>) -> String {
    if *p == Isometry3::identity() {
        return String::new();
    }
    let t = p.translation.vector * 1e3;
    let (r, pi, y) = p.rotation.euler_angles();
    let mut s = format!("  at xyz ({:.1}, {:.1}, {:.1}) mm", t.x, t.y, t.z);
    if p.rotation.angle() > 1e-12 {
        s += &format!(
            " rpy ({:.1}, {:.1}, {:.1}) deg",
            r.to_degrees(),
            pi.to_degrees(),
            y.to_degrees()
        );
    }
    s
}

impl Robot {
    /// The `dexwarp robot` report (same as `to_string()`).
    pub fn describe(&self) -> String {
        self.to_string()
    }
}

impl Display for Robot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_summary(f)?;
        writeln!(f)?;
        self.write_joints(f)?;
        writeln!(f)?;
        self.write_links(f)
    }
}

impl Robot {
    /// The summary: name and file, link and joint counts, DoF, root link, surface points.
    fn write_summary(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let count = |k: JointKind| self.joints.iter().filter(|j| j.kind == k).count();
        let mimics = self.joints.iter().filter(|j| j.mimic.is_some()).count();
        writeln!(f, "robot '{}'  ({})", self.name, self.source.display())?;
        writeln!(
            f,
            "  {} links, {} joints: {} revolute, {} continuous, {} prismatic, {} fixed; {} mimic",
            self.links.len(),
            self.joints.len(),
            count(JointKind::Revolute),
            count(JointKind::Continuous),
            count(JointKind::Prismatic),
            count(JointKind::Fixed),
            mimics
        )?;
        writeln!(
            f,
            "  DoF: 6 (floating wrist) + {} actuated = {}",
            self.dof(),
            6 + self.dof()
        )?;
        writeln!(
            f,
            "  root link: '{}' (its world pose is the wrist)",
            self.link(self.root).name
        )?;
        writeln!(
            f,
            "  surface points: {} (for contacts and the IK barrier)",
            self.surface_point_count()
        )?;
        Ok(())
    }

    /// The joint table in tree order, columns sized to the content.
    fn write_joints(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "joints (tree order; q index for actuated joints):")?;
        let rows: Vec<[String; 6]> = self
            .joints
            .iter()
            .map(|j| {
                let q = j.dof.map_or_else(|| "-".into(), |i| i.to_string());
                let link = |id| self.link(id).name.clone();
                let unit = if j.kind == JointKind::Prismatic {
                    "m"
                } else {
                    "rad"
                };
                let range = match (j.kind, j.limits) {
                    (JointKind::Fixed, _) => String::new(),
                    (JointKind::Continuous, _) => format!("unlimited {unit}"),
                    (_, Some((lo, hi))) => format!("[{}, {}] {unit}", limit(lo), limit(hi)),
                    (_, None) => format!("unlimited {unit}"),
                };
                let mimic = match (&j.mimic, &j.mimic_source) {
                    (Some(m), Some(src)) => {
                        let driver = &self.joint(self.actuated[m.driver]).name;
                        let via = if src != driver {
                            format!(" (via '{src}')")
                        } else {
                            String::new()
                        };
                        format!(
                            "= {} * {driver} {} {}{via}",
                            coef(m.multiplier),
                            if m.offset < 0.0 { '-' } else { '+' },
                            coef(m.offset.abs())
                        )
                    }
                    _ => String::new(),
                };
                [
                    q,
                    j.name.clone(),
                    j.kind.as_str().into(),
                    format!("{} -> {}", link(j.parent), link(j.child)),
                    range,
                    mimic,
                ]
            })
            .collect();
        let header = ["q", "name", "type", "parent -> child", "limits", "mimic"];
        let mut width = header.map(str::len);
        for r in &rows {
            for (w, c) in width.iter_mut().zip(r) {
                *w = (*w).max(c.chars().count());
            }
        }
        let line = |f: &mut fmt::Formatter<'_>, cells: [&str; 6]| -> fmt::Result {
            let mut s = String::from("  ");
            for (k, (c, w)) in cells.iter().zip(width).enumerate() {
                if k == 0 {
                    s += &format!("{c:>w$}  ");
                } else {
                    s += &format!("{c:<w$}  ");
                }
            }
            writeln!(f, "{}", s.trim_end())
        };
        line(f, header)?;
        for r in &rows {
            line(f, r.each_ref().map(String::as_str))?;
        }
        Ok(())
    }

    /// Per link: its collision shapes and surface points.
    fn write_links(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "links (collision shapes in the link frame):")?;
        for l in &self.links {
            if l.collision.is_empty() {
                writeln!(f, "  {}: no collision geometry", l.name)?;
                continue;
            }
            writeln!(
                f,
                "  {}: {} shape{}, {} surface points",
                l.name,
                l.collision.len(),
                if l.collision.len() == 1 { "" } else { "s" },
                l.surface_points.len()
            )?;
            for c in &l.collision {
                writeln!(f, "    {}", shape_line(c))?;
            }
        }
        Ok(())
    }
}

/// One collision shape: the dimensions, then the origin when it is not the identity.
fn shape_line(c: &CollisionShape) -> String {
    format!("{}{}", c.describe(), pose(&c.origin))
}
