//! Forward simulation: the state derivative `(q̇, v̇) = (N(q)·v, ABA(q, v, τ_act + τ_passive,
//! f_contact))` and classic fixed-step fourth-order Runge–Kutta rollouts, generic over the scalar.
//!
//! One RK4 step of size `h` from `(t, x)`: `k₁ = f(t, x)`, `k₂ = f(t + h/2, x + h/2·k₁)`,
//! `k₃ = f(t + h/2, x + h/2·k₂)`, `k₄ = f(t + h, x + h·k₃)`,
//! `x ← x + h/6·(k₁ + 2k₂ + 2k₃ + k₄)`, then a floating base's quaternion is renormalized.
//! Controls are actuator forces (N·m or N), or a servo's set-point offsets (rad or m; see
//! [`crate::gait::character::Servo`]), as functions of time, evaluated at the stage times. The
//! actuator effort `∫ Σ τ² dt` is integrated alongside with the same weights
//! ([`Simulator::effort`]).
//! A step whose state is not finite (e.g. a contact point driven far below the ground, where the
//! contact spring's exponential overflows) is reported as a [`SimError`], as is a raised
//! interrupt flag ([`Simulator::interruptible`], polled every
//! [`STEPS_BETWEEN_POLLS`] steps).

use super::aba::Dynamics;
use super::character::Model;
use super::contact::add_contact_forces;
use super::spatial::{Force, Real};
use crate::solver::Interrupt;
use crate::solver::interrupt::STEPS_BETWEEN_POLLS;

/// The simulation left the domain where it is defined, or was interrupted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{} at t = {time} s", if *.interrupted { "simulation interrupted" } else { "simulation state not finite" })]
pub struct SimError {
    /// Time of the failed step (s).
    pub time: f64,
    /// The run's interrupt flag stopped the simulation (the state was finite).
    pub interrupted: bool,
}

impl SimError {
    /// The state was not finite after the step ending at `time` (s).
    pub fn not_finite(time: f64) -> Self {
        SimError {
            time,
            interrupted: false,
        }
    }

    /// The interrupt flag was raised before the step starting at `time` (s).
    pub fn interrupted(time: f64) -> Self {
        SimError {
            time,
            interrupted: true,
        }
    }
}

/// `Err(SimError::interrupted(t))` if `step` is a polling step and `interrupt` is raised.
pub fn poll(interrupt: Option<&Interrupt>, step: usize, t: f64) -> Result<(), SimError> {
    match interrupt {
        Some(flag) if step.is_multiple_of(STEPS_BETWEEN_POLLS) && flag.is_raised() => {
            Err(SimError::interrupted(t))
        }
        _ => Ok(()),
    }
}

/// Actuator controls as functions of time: fills `out` (one per actuator: the force, N·m or N,
/// or a servo's set-point offset, rad or m) at `t` (s).
pub trait Controls<T> {
    /// Actuator controls at time `t`.
    fn forces(&self, t: f64, out: &mut [T]);
}

impl<T, F: Fn(f64, &mut [T])> Controls<T> for F {
    fn forces(&self, t: f64, out: &mut [T]) {
        self(t, out)
    }
}

/// A simulation state: generalized coordinates and velocities.
#[derive(Debug, Clone, PartialEq)]
pub struct State<T> {
    /// Coordinates (length nq).
    pub q: Vec<T>,
    /// Velocities (length nv).
    pub v: Vec<T>,
}

/// Reusable simulator: dynamics scratch space and RK4 stage buffers.
#[derive(Debug, Clone)]
pub struct Simulator<'m, T> {
    model: &'m Model,
    /// Dynamics scratch; after [`Simulator::observe`] it holds the kinematics of that state.
    pub dynamics: Dynamics<T>,
    f_ext: Vec<Force<T>>,
    act: Vec<T>,
    tau: Vec<T>,
    kq: [Vec<T>; 4],
    kv: [Vec<T>; 4],
    tmp: State<T>,
    /// Polled every [`STEPS_BETWEEN_POLLS`] steps, if any.
    interrupt: Option<Interrupt>,
    /// Steps taken.
    steps: usize,
    /// `Σ τ²` of the actuator forces at the last [`Simulator::derivative`] (N²·m² or N²).
    stage_effort: T,
    /// The actuator effort `∫ Σ τ² dt` over the steps taken (N²·s), by the RK4 quadrature of
    /// the step (the effort as a state `ė = Σ τ²` integrated with the motion).
    pub effort: T,
}

impl<'m, T: Real> Simulator<'m, T> {
    /// A simulator for `model`.
    pub fn new(model: &'m Model) -> Self {
        let z = |n| vec![T::zero(); n];
        Simulator {
            model,
            dynamics: Dynamics::new(model),
            f_ext: vec![Force::zero(); model.links.len()],
            act: z(model.actuators.len()),
            tau: z(model.nv),
            kq: std::array::from_fn(|_| z(model.nq)),
            kv: std::array::from_fn(|_| z(model.nv)),
            tmp: State {
                q: z(model.nq),
                v: z(model.nv),
            },
            interrupt: None,
            steps: 0,
            stage_effort: T::zero(),
            effort: T::zero(),
        }
    }

    /// The same simulator, stopping with [`SimError::interrupted`] once `interrupt` is raised
    /// (polled every [`STEPS_BETWEEN_POLLS`] steps).
    pub fn interruptible(mut self, interrupt: &Interrupt) -> Self {
        self.interrupt = Some(interrupt.clone());
        self
    }

    /// The model simulated.
    pub fn model(&self) -> &'m Model {
        self.model
    }

    /// The state derivative `(q̇, v̇)` at time `t`.
    pub fn derivative(
        &mut self,
        t: f64,
        x: &State<T>,
        controls: &dyn Controls<T>,
        qd: &mut [T],
        vd: &mut [T],
    ) {
        let m = self.model;
        self.dynamics.kinematics(m, &x.q, &x.v);
        self.f_ext.fill(Force::zero());
        add_contact_forces(m, &self.dynamics, &mut self.f_ext);
        self.tau.fill(T::zero());
        m.add_passive(&x.q, &x.v, &mut self.tau);
        controls.forces(t, &mut self.act);
        self.stage_effort = m.add_actuators(&self.act, &x.q, &x.v, &mut self.tau);
        m.qdot(&x.q, &x.v, qd);
        self.dynamics.accelerations(m, &self.tau, &self.f_ext, vd);
    }

    /// Advances `x` by one RK4 step of `h` seconds from time `t`.
    pub fn step(
        &mut self,
        t: f64,
        h: f64,
        x: &mut State<T>,
        controls: &dyn Controls<T>,
    ) -> Result<(), SimError> {
        poll(self.interrupt.as_ref(), self.steps, t)?;
        self.steps += 1;
        let mut kq = std::mem::take(&mut self.kq);
        let mut kv = std::mem::take(&mut self.kv);
        let mut tmp = std::mem::replace(
            &mut self.tmp,
            State {
                q: Vec::new(),
                v: Vec::new(),
            },
        );
        let stages = [(0.0, 0.0), (0.5, 0.5), (0.5, 0.5), (1.0, 1.0)];
        let mut effort = T::zero();
        for (s, &(dt_frac, x_frac)) in stages.iter().enumerate() {
            if s == 0 {
                tmp.q.copy_from_slice(&x.q);
                tmp.v.copy_from_slice(&x.v);
            } else {
                let w = h * x_frac;
                for ((t, x0), k) in tmp.q.iter_mut().zip(&x.q).zip(&kq[s - 1]) {
                    *t = *x0 + *k * w;
                }
                for ((t, x0), k) in tmp.v.iter_mut().zip(&x.v).zip(&kv[s - 1]) {
                    *t = *x0 + *k * w;
                }
            }
            let (qd, vd) = (&mut kq[s], &mut kv[s]);
            self.derivative(t + dt_frac * h, &tmp, controls, qd, vd);
            effort += self.stage_effort * if s == 1 || s == 2 { 2.0 } else { 1.0 };
        }
        let w = h / 6.0;
        self.effort += effort * w;
        let combine = |x: &mut [T], k: &[Vec<T>; 4]| {
            for (j, xj) in x.iter_mut().enumerate() {
                *xj += (k[0][j] + (k[1][j] + k[2][j]) * 2.0 + k[3][j]) * w;
            }
        };
        combine(&mut x.q, &kq);
        combine(&mut x.v, &kv);
        self.model.normalize(&mut x.q);
        self.kq = kq;
        self.kv = kv;
        self.tmp = tmp;
        if x.q.iter().chain(&x.v).all(|z| z.re().is_finite()) {
            Ok(())
        } else {
            Err(SimError::not_finite(t + h))
        }
    }

    /// Runs kinematics at state `x` so that [`Simulator::dynamics`] can be read out (point
    /// positions and velocities, centre of mass, energies).
    pub fn observe(&mut self, x: &State<T>) {
        self.dynamics.kinematics(self.model, &x.q, &x.v);
    }

    /// Simulates from `x` at `t = 0` with steps of `h` for `steps[last]` steps, calling
    /// `sample(k, x, self)` after step `steps[k]` (ascending step counts; 0 means the initial
    /// state) with the state's kinematics computed.
    pub fn rollout(
        &mut self,
        x: &mut State<T>,
        h: f64,
        steps: &[usize],
        controls: &dyn Controls<T>,
        mut sample: impl FnMut(usize, &State<T>, &Self),
    ) -> Result<(), SimError> {
        self.rollout_while(x, h, steps, controls, |k, x, sim| {
            sample(k, x, sim);
            true
        })
    }

    /// [`Simulator::rollout`], ending after the first sample for which `sample` returns
    /// `false` (the later steps are not taken).
    pub fn rollout_while(
        &mut self,
        x: &mut State<T>,
        h: f64,
        steps: &[usize],
        controls: &dyn Controls<T>,
        mut sample: impl FnMut(usize, &State<T>, &Self) -> bool,
    ) -> Result<(), SimError> {
        let mut n = 0;
        for (k, &target) in steps.iter().enumerate() {
            while n < target {
                self.step(n as f64 * h, h, x, controls)?;
                n += 1;
            }
            self.observe(x);
            if !sample(k, x, self) {
                break;
            }
        }
        Ok(())
    }
}
