//! Binding a demonstration to its robot.

use super::Robot;
use crate::model::Demo;
use crate::{Error, Limits, Result};

impl Demo {
    /// Loads the demonstration's robot, rooted at its `wrist_link` when it names one.
    pub fn load_robot(&self, limits: &Limits) -> Result<Robot> {
        Robot::from_urdf_file_at(&self.robot, limits, self.wrist_link.as_deref())
    }

    /// Checks the demonstration against its robot and reorders every frame's joints into the
    /// robot's actuated order (so `frames[i].joints[k]` is actuated joint `k`). Fails with
    /// the JSON path when a joint or contact link does not exist on the robot.
    pub fn check_robot(&mut self, robot: &Robot) -> Result<()> {
        let path = self.source.as_path();
        let mut order = vec![usize::MAX; self.joint_names.len()];
        for (j, name) in self.joint_names.iter().enumerate() {
            match robot.actuated_index(name) {
                Some(k) => order[j] = k,
                None => {
                    let hint = if robot.joint_id(name).is_some() {
                        "is a fixed or mimic joint of the robot; list only actuated joints"
                            .to_string()
                    } else {
                        format!(
                            "is not a joint of robot {:?}; expected one of its actuated joints: {}",
                            robot.name,
                            robot.actuated_names().join(", ")
                        )
                    };
                    return Err(Error::invalid(
                        path,
                        format!("joint_names[{j}]"),
                        format!("{name:?} {hint}"),
                    ));
                }
            }
        }
        if self.joint_names.len() != robot.dof() {
            let listed: std::collections::HashSet<&str> =
                self.joint_names.iter().map(String::as_str).collect();
            let missing: Vec<String> = robot
                .actuated_names()
                .into_iter()
                .filter(|n| !listed.contains(n.as_str()))
                .collect();
            return Err(Error::invalid(
                path,
                "joint_names",
                format!(
                    "lists {} joints; robot {:?} has {} actuated joints; missing: {}",
                    self.joint_names.len(),
                    robot.name,
                    robot.dof(),
                    missing.join(", ")
                ),
            ));
        }
        for (i, frame) in self.frames.iter_mut().enumerate() {
            for (k, contact) in frame.contacts.iter().enumerate() {
                if robot.link_id(&contact.link).is_none() {
                    return Err(Error::invalid(
                        path,
                        format!("frames[{i}].contacts[{k}].link"),
                        format!("{:?} is not a link of robot {:?}", contact.link, robot.name),
                    ));
                }
            }
            let mut q = vec![0.0; robot.dof()];
            for (j, &k) in order.iter().enumerate() {
                q[k] = frame.joints[j];
            }
            frame.joints = q;
        }
        self.joint_names = robot.actuated_names();
        Ok(())
    }
}
