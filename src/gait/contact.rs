//! Ground contact: the seed's smooth nonlinear spring (Anderson & Pandy's model with the seed's
//! constants, eq. 3.26–3.27) at every contact point, plus regularized Coulomb friction.
//!
//! For a contact point at height `p_y` above the ground plane (m) moving with world velocity
//! `(ṗ_x, ṗ_y, ṗ_z)` (m/s), the ground pushes on the point with
//! ```text
//!   normal   F_y = a·e^(−b(p_y − y₀)) − d·ṗ_y·g(p_y),   g(p_y) = 1 / (1 + k·e^(r(p_y − g₀)))
//!   friction F_t = −μ·F_s·ṽ_t / √(|ṽ_t|² + v_s²),      F_s = a·e^(−b(p_y − y₀)),  ṽ_t = (ṗ_x, ṗ_z)
//! ```
//! seed values a = 0.5336 N, b = 700 /m, y₀ = 0.0035423 m, d = 1000 N·s/m, k = 10, r = 200 /m,
//! g₀ = 0.005 m. As in the seed the springs stay attached at all times (negligible force more
//! than ~5 mm above the ground) and the normal law is applied as written: the damping term can
//! pull briefly on a point leaving the ground fast. Friction scales with the elastic part `F_s`
//! (always positive and smooth, equal to the supported weight at rest); it approaches Coulomb's
//! `μF_s` opposing the slip once the slip speed exceeds a few `v_s`, and is smooth at zero slip.

use super::aba::Dynamics;
use super::character::{ContactParams, Model};
use super::spatial::{Force, Real, Vec3};

/// Elastic part of the normal force (N) at height `h` (m) above the ground.
pub fn spring_force<T: Real>(p: &ContactParams, h: T) -> T {
    ((h - p.spring_offset) * (-p.spring_rate)).exp() * p.spring_force
}

/// The damping switch `g(h) = 1/(1 + k·e^(r(h − g₀)))` (dimensionless).
pub fn damping_switch<T: Real>(p: &ContactParams, h: T) -> T {
    (((h - p.damping_offset) * p.damping_rate).exp() * p.damping_factor + 1.0).recip()
}

/// Normal force (N, positive up) at height `h` (m) with vertical speed `vy` (m/s); eq. 3.26.
pub fn normal_force<T: Real>(p: &ContactParams, h: T, vy: T) -> T {
    spring_force(p, h) - vy * damping_switch(p, h) * p.damping
}

/// The world force (N) the ground exerts on a point at world position `pos` moving with `vel`.
pub fn contact_force<T: Real>(p: &ContactParams, pos: &Vec3<T>, vel: &Vec3<T>) -> Vec3<T> {
    let h = pos.0[1] - p.ground;
    let fy = normal_force(p, h, vel.0[1]);
    let (vx, vz) = (vel.0[0], vel.0[2]);
    let slip = (vx * vx + vz * vz + p.slip_speed * p.slip_speed).sqrt();
    let scale = -(spring_force(p, h) * p.friction) / slip;
    Vec3([vx * scale, fy, vz * scale])
}

/// Adds the contact forces of every contact point to `f_ext` (link coordinates). Call after
/// [`Dynamics::kinematics`].
pub fn add_contact_forces<T: Real>(model: &Model, dynamics: &Dynamics<T>, f_ext: &mut [Force<T>]) {
    for (i, l) in model.links.iter().enumerate() {
        for point in &l.contacts {
            let p = Vec3::from_f64(*point);
            let pos = dynamics.point_position(i, &p);
            let vel = dynamics.point_velocity(i, &p);
            let f_world = contact_force(&model.contact, &pos, &vel);
            let f_link = dynamics.world[i].e.mul_vec(&f_world);
            f_ext[i] += Force::at_point(&p, &f_link);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 3.26–3.27 typed in directly from the seed, for pointwise comparison.
    fn seed_law(py: f64, vy: f64) -> f64 {
        let g = 1.0 / (1.0 + 10.0 * (200.0 * (py - 0.005)).exp());
        0.5336 * (-700.0 * (py - 0.0035423)).exp() - 1000.0 * vy * g
    }

    #[test]
    fn normal_force_matches_seed_equations() {
        let p = ContactParams::default();
        for i in 0..=60 {
            let py = -0.01 + 0.0005 * i as f64;
            for vy in [-1.5, -0.2, 0.0, 0.3, 2.0] {
                let ours = normal_force(&p, py, vy);
                let seed = seed_law(py, vy);
                assert!(
                    (ours - seed).abs() <= 1e-12 * seed.abs().max(1.0),
                    "{py} {vy}: {ours} vs {seed}"
                );
                let f = contact_force(&p, &Vec3([0.3, py, -0.1]), &Vec3([0.0, vy, 0.0]));
                assert!((f.0[1] - seed).abs() <= 1e-12 * seed.abs().max(1.0));
            }
        }
        // Anchors: 0.5336 N at y₀; more than 5 mm up the force is negligible (< 0.2 N).
        assert!((normal_force(&p, 0.0035423f64, 0.0) - 0.5336).abs() < 1e-15);
        assert!(normal_force(&p, 0.005, 0.0) < 0.2);
    }

    #[test]
    fn friction_opposes_slip_and_tends_to_coulomb() {
        let p = ContactParams::default();
        let h = 0.0f64;
        let fs = spring_force(&p, h);
        let f = contact_force(&p, &Vec3([0.0, h, 0.0]), &Vec3([1.0, 0.0, -1.0]));
        let ft = (f.0[0] * f.0[0] + f.0[2] * f.0[2]).sqrt();
        assert!(f.0[0] < 0.0 && f.0[2] > 0.0);
        assert!((ft - p.friction * fs).abs() < 1e-4 * fs);
        let still = contact_force(&p, &Vec3([0.0, h, 0.0]), &Vec3([0.0, 0.0, 0.0]));
        assert_eq!((still.0[0], still.0[2]), (0.0, 0.0));
    }
}
