//! The `lm` solver: damped Gauss-Newton / Levenberg-Marquardt on the model of the module docs.

use nalgebra::{Isometry3, Vector3};

use super::*;

impl IkSolver<'_> {
    /// `H += rowᵀ row`, `g += rowᵀ e` on the columns `cols` (lower triangle of `H`).
    #[inline]
    pub(super) fn add_row(
        h: &mut [f64],
        g: &mut [f64],
        n: usize,
        cols: &[usize],
        row: &[f64],
        e: f64,
    ) {
        for (k, &a) in cols.iter().enumerate() {
            let ra = row[a];
            g[a] += ra * e;
            for &b in &cols[..=k] {
                h[a + b * n] += ra * row[b];
            }
        }
    }

    /// Fills `H` (full, symmetric) and `g` of the Gauss-Newton model at `self.poses`
    /// (see the module docs for the rows), with the active points `self.hits` that
    /// [`IkSolver::evaluate`] found there.
    pub(super) fn linearize(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &Isometry3<f64>,
        q: &[f64],
    ) {
        let n = self.n;
        self.h.fill(0.0);
        self.g.fill(0.0);
        let geo = &self.geo;
        let robot = geo.robot;
        let poses = &self.poses[..];
        let hits = &self.hits;
        let h = self.h.as_mut_slice();
        let g = self.g.as_mut_slice();
        let jac = &mut self.jac[..];
        let row = &mut self.row[..];
        let nc = contacts.len();
        for c in contacts {
            let l = c.link.index();
            let ph = poses[l] * c.hand_point;
            let r = ph - object_pose * c.object_point;
            let w = 1.0 / (2.0 * nc as f64 * r.norm().max(CONTACT_FLOOR_M));
            robot.world_point_jacobian(poses, c.link, &ph, jac);
            let cols = geo.cols(l);
            for (k, &a) in cols.iter().enumerate() {
                g[a] += w * jac[a].dot(&r);
                for &b in &cols[..=k] {
                    h[a + b * n] += w * jac[a].dot(&jac[b]);
                }
            }
        }
        let p = &self.params;
        if p.barrier_weight > 0.0 && p.objective == Objective::Paper {
            let (m, half) = (p.margin_m, p.steepness / 2.0);
            let sw = p.barrier_weight.sqrt();
            for hit in &hits.barrier {
                let gap = (1.0 - hit.d / m).max(1e-9);
                let e = sw * gap.powf(half);
                let coeff = -sw * half * gap.powf(half - 1.0) / m;
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                let cols = geo.cols(hit.link as usize);
                for &a in cols {
                    row[a] = coeff * hit.grad.dot(&jac[a]);
                }
                Self::add_row(h, g, n, cols, row, e);
            }
        } else if p.barrier_weight > 0.0 {
            // The clearance hinge: e = sw (c − SDF)/s, ∂e/∂θ = −(sw/s) ∇SDFᵀ J.
            let c = p.barrier_clearance_mm * 1e-3;
            let sw = p.barrier_weight.sqrt();
            for hit in &hits.barrier {
                let e = sw * (c - hit.d) / DEPTH_SCALE_M;
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                let cols = geo.cols(hit.link as usize);
                for &a in cols {
                    row[a] = -sw / DEPTH_SCALE_M * hit.grad.dot(&jac[a]);
                }
                Self::add_row(h, g, n, cols, row, e);
            }
        }
        if self.surface_obstacle.is_some() {
            let m = p.margin_m;
            let sw = p.surface_penetration_weight.sqrt();
            for hit in &hits.surface {
                let e = sw * (-hit.d) / m;
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                let cols = geo.cols(hit.link as usize);
                for &a in cols {
                    row[a] = -sw / m * hit.grad.dot(&jac[a]);
                }
                Self::add_row(h, g, n, cols, row, e);
            }
        }
        if geo.object.is_some() && self.object_from_world.is_some() {
            let a = 0.5 * p.penetration_tolerance_mm * 1e-3;
            let sw = p.penetration_weight.sqrt();
            for hit in &hits.probes {
                // e = sw (depth − a)/s, depth = r − φ(c): ∂e/∂θ = −(sw/s) ∇φᵀ J_c.
                let e = sw * (hit.d - a) / DEPTH_SCALE_M;
                robot.world_point_jacobian(poses, LinkId(hit.link), &hit.point, jac);
                let cols = geo.cols(hit.link as usize);
                for &k in cols {
                    row[k] = -sw / DEPTH_SCALE_M * hit.grad.dot(&jac[k]);
                }
                Self::add_row(h, g, n, cols, row, e);
            }
        }
        if p.regularization > 0.0 {
            let rho = p.regularization;
            let s2 = 1.0 / (TRANSLATION_SCALE_M * TRANSLATION_SCALE_M);
            let dt = wrist.translation.vector - self.wrist0.translation.vector;
            let dr = (wrist.rotation * self.wrist0.rotation.inverse()).scaled_axis();
            for k in 0..3 {
                h[k + k * n] += rho * s2;
                g[k] += rho * s2 * dt[k];
                h[(k + 3) + (k + 3) * n] += rho;
                g[k + 3] += rho * dr[k];
            }
            for (j, (a, b)) in q.iter().zip(&self.q0).enumerate() {
                let c = WRIST_DOF + j;
                h[c + c * n] += rho;
                g[c] += rho * (a - b);
            }
        }
        // Mirror the lower triangle.
        for b in 0..n {
            for a in b + 1..n {
                h[b + a * n] = h[a + b * n];
            }
        }
    }

    /// Decrease of the model Σe² that the step predicts: −2δᵀg − δᵀHδ (= δᵀHδ + 2μδᵀDδ > 0).
    fn predicted_decrease(&self) -> f64 {
        let n = self.n;
        let mut pred = 0.0;
        for a in 0..n {
            let da = self.step[a];
            if da == 0.0 {
                continue;
            }
            let mut hrow = 0.0;
            for b in 0..n {
                hrow += self.h[(a, b)] * self.step[b];
            }
            pred += -2.0 * da * self.g[a] - da * hrow;
        }
        pred
    }

    /// Levenberg-Marquardt (see the module docs) from `start`, the evaluation of the warm
    /// start (with `self.poses` and `self.hits` at it). Returns (converged, iterations,
    /// eval, whether the iteration cap ended it).
    pub(super) fn solve_lm(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &mut Isometry3<f64>,
        q: &mut [f64],
        start: Eval,
    ) -> (bool, usize, Eval, bool) {
        let n = self.n;
        let nc = contacts.len();
        let cap = self.params.iteration_cap();
        let robot = self.geo.robot;
        let mut cur = start;
        let mut iterations = 0;
        let (mut mu, mut nu) = (MU_INIT, 2.0);
        let mut stale = true;
        let mut stalled = false;
        let mut stalls = 0;
        loop {
            if self.meets_stop_rule(&cur, nc) {
                return (true, iterations, cur, false);
            }
            if iterations >= cap || mu > MU_MAX {
                return (false, iterations, cur, iterations >= cap);
            }
            if stale {
                self.linearize(object_pose, contacts, wrist, q);
                for k in 0..n {
                    self.diag[k] = self.h[(k, k)].max(1e-12);
                }
                // Joints at a limit whose descent direction points outward stay frozen.
                for j in 0..robot.dof() {
                    let c = WRIST_DOF + j;
                    let gj = self.g[c];
                    self.frozen[c] = (q[j] <= robot.lower()[j] && gj > 0.0)
                        || (q[j] >= robot.upper()[j] && gj < 0.0);
                }
                stale = false;
            }
            iterations += 1;
            self.a.copy_from(&self.h);
            for k in 0..n {
                self.a[(k, k)] += mu * self.diag[k];
            }
            for c in 0..n {
                if self.frozen[c] {
                    self.a.row_mut(c).fill(0.0);
                    self.a.column_mut(c).fill(0.0);
                    self.a[(c, c)] = 1.0;
                }
            }
            let a = std::mem::replace(&mut self.a, DMatrix::zeros(0, 0));
            let Some(chol) = Cholesky::new(a) else {
                // Not positive definite (only through round-off): damp harder. The consumed
                // storage is reallocated on this rare path only.
                self.a = DMatrix::zeros(n, n);
                mu *= nu;
                nu *= 2.0;
                continue;
            };
            self.step.copy_from(&self.g);
            for c in 0..n {
                if self.frozen[c] {
                    self.step[c] = 0.0;
                }
            }
            self.step.neg_mut();
            chol.solve_mut(&mut self.step);
            self.a = chol.unpack_dirty();
            let pred = self.predicted_decrease();
            let mut trial_wrist = *wrist;
            let s = &self.step;
            apply_wrist_step(
                &mut trial_wrist,
                &Vector3::new(s[0], s[1], s[2]),
                &Vector3::new(s[3], s[4], s[5]),
            );
            for j in 0..q.len() {
                self.q_trial[j] = q[j] + s[WRIST_DOF + j];
            }
            robot.clamp(&mut self.q_trial);
            let q_trial = std::mem::take(&mut self.q_trial);
            let next = self.evaluate(true, object_pose, contacts, &trial_wrist, &q_trial);
            self.q_trial = q_trial;
            let gain = (cur.total(nc) - next.total(nc)) / pred.max(1e-300);
            if gain > 0.0 && next.total(nc).is_finite() {
                // Decreases below `stall_decrease` of F, `stall_steps` in a row, cannot carry
                // the frame to the threshold in any useful number of iterations: a local
                // minimum. (One alone may be a step shortened by raised damping.)
                if cur.total(nc) - next.total(nc) < self.params.stall_decrease * cur.total(nc) {
                    stalls += 1;
                } else {
                    stalls = 0;
                }
                stalled = stalls >= self.params.stall_steps.max(1);
                *wrist = trial_wrist;
                q.copy_from_slice(&self.q_trial);
                std::mem::swap(&mut self.poses, &mut self.trial_poses);
                std::mem::swap(&mut self.hits, &mut self.trial_hits);
                cur = next;
                mu *= (1.0 - (2.0 * gain - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                stale = true;
            } else {
                mu *= nu;
                nu *= 2.0;
            }
            if (stalled || self.step.amax() < STALL_STEP) && !self.meets_stop_rule(&cur, nc) {
                // No progress without meeting the stop rule: a local minimum.
                return (false, iterations, cur, false);
            }
        }
    }
}
