//! The `adam` solver: the paper's Adam on exactly the printed objective.

use nalgebra::{Isometry3, Vector3};

use super::*;

impl IkSolver<'_> {
    /// The paper's Adam (see the module docs) from `start`, the evaluation of the warm
    /// start (with `self.poses` and `self.hits` at it). Returns (converged, iterations, eval,
    /// whether the iteration cap ended it). Adam's steps may raise `F`: the best iterate
    /// visited is what it returns, so a frame never ends worse than its warm start.
    pub(super) fn solve_adam(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &mut Isometry3<f64>,
        q: &mut [f64],
        start: Eval,
    ) -> (bool, usize, Eval, bool) {
        const B1: f64 = 0.9;
        const B2: f64 = 0.999;
        const EPS: f64 = 1e-8;
        let nc = contacts.len();
        let cap = self.params.iteration_cap();
        let lr = self.params.learning_rate;
        let robot = self.geo.robot;
        self.adam_m.fill(0.0);
        self.adam_v.fill(0.0);
        let (mut b1t, mut b2t) = (1.0, 1.0);
        let mut iterations = 0;
        let mut best: Option<(f64, Isometry3<f64>, Eval)> = None;
        let mut cur = start;
        loop {
            if self.meets_stop_rule(&cur, nc) {
                return (true, iterations, cur, false);
            }
            if best.as_ref().is_none_or(|(f, _, _)| cur.total(nc) < *f) {
                best = Some((cur.total(nc), *wrist, cur));
                self.q_trial.copy_from_slice(q);
            }
            if iterations >= cap {
                let (_, w, e) = best.expect("set above");
                *wrist = w;
                q.copy_from_slice(&self.q_trial);
                return (false, iterations, e, true);
            }
            self.gradient(object_pose, contacts);
            iterations += 1;
            b1t *= B1;
            b2t *= B2;
            for k in 0..self.n {
                let gk = self.g[k];
                self.adam_m[k] = B1 * self.adam_m[k] + (1.0 - B1) * gk;
                self.adam_v[k] = B2 * self.adam_v[k] + (1.0 - B2) * gk * gk;
                let mh = self.adam_m[k] / (1.0 - b1t);
                let vh = self.adam_v[k] / (1.0 - b2t);
                self.step[k] = -lr * mh / (vh.sqrt() + EPS);
            }
            let s = &self.step;
            apply_wrist_step(
                wrist,
                &Vector3::new(s[0], s[1], s[2]),
                &Vector3::new(s[3], s[4], s[5]),
            );
            for j in 0..q.len() {
                q[j] += s[WRIST_DOF + j];
            }
            robot.clamp(q);
            cur = self.evaluate(false, object_pose, contacts, wrist, q);
        }
    }

    /// `g = ∇F` at `self.poses` (exactly the printed objective, no proximal term), with the
    /// active points `self.hits` that [`IkSolver::evaluate`] found there.
    pub(super) fn gradient(&mut self, object_pose: &Isometry3<f64>, contacts: &[ResolvedContact]) {
        self.g.fill(0.0);
        let geo = &self.geo;
        let robot = geo.robot;
        let poses = &self.poses[..];
        let g = self.g.as_mut_slice();
        let jac = &mut self.jac[..];
        let inv_n = 1.0 / contacts.len().max(1) as f64;
        for c in contacts {
            let l = c.link.index();
            let ph = poses[l] * c.hand_point;
            let r = ph - object_pose * c.object_point;
            let d = r.norm();
            if d < 1e-15 {
                continue;
            }
            let u = r * (inv_n / d);
            robot.world_point_jacobian(poses, c.link, &ph, jac);
            for &a in geo.cols(l) {
                g[a] += u.dot(&jac[a]);
            }
        }
        let p = &self.params;
        let hits = &self.hits;
        if p.barrier_weight > 0.0 && p.objective == Objective::Paper {
            let (m, n, w) = (p.margin_m, p.steepness, p.barrier_weight);
            for hit in &hits.barrier {
                let gap = 1.0 - hit.d / m;
                let coeff = -w * n * gap.powf(n - 1.0) / m;
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                for &a in geo.cols(hit.link as usize) {
                    g[a] += coeff * hit.grad.dot(&jac[a]);
                }
            }
        } else if p.barrier_weight > 0.0 {
            // d(w ((c − SDF)/s)²) = −2w (c − SDF)/s² ∇SDF.
            let (c, w) = (p.barrier_clearance_mm * 1e-3, p.barrier_weight);
            for hit in &hits.barrier {
                let coeff = -2.0 * w * (c - hit.d) / (DEPTH_SCALE_M * DEPTH_SCALE_M);
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                for &k in geo.cols(hit.link as usize) {
                    g[k] += coeff * hit.grad.dot(&jac[k]);
                }
            }
        }
        if self.surface_obstacle.is_some() {
            let (m, w) = (p.margin_m, p.surface_penetration_weight);
            for hit in &hits.surface {
                // d(w (−d/m)²) = 2w d/m² ∇d.
                let coeff = 2.0 * w * hit.d / (m * m);
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                for &a in geo.cols(hit.link as usize) {
                    g[a] += coeff * hit.grad.dot(&jac[a]);
                }
            }
        }
        if geo.object.is_some() && self.object_from_world.is_some() {
            let a = 0.5 * p.penetration_tolerance_mm * 1e-3;
            let w = p.penetration_weight;
            for hit in &hits.probes {
                // d(w ((depth − a)/s)²) = −2w (depth − a)/s² ∇φ.
                let coeff = -2.0 * w * (hit.d - a) / (DEPTH_SCALE_M * DEPTH_SCALE_M);
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                for &k in geo.cols(hit.link as usize) {
                    g[k] += coeff * hit.grad.dot(&jac[k]);
                }
            }
        }
    }
}
