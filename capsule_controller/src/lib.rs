//! The capsule's controller, without ROS or I/O: the modes that set the gain of the paper's law
//! (Liu et al. 2014, eq. 2-3: the harmonic drive plus `u = k_p |x2 - x1|`, which is
//! `capsule_plant::AffineLaw`, the one actuator-law type), attractor switching by a gain pulse,
//! move goals (travel a distance and stop, [`move_goal`]), and the velocities a real capsule
//! does not measure.
//!
//! Everything here is non-dimensional (the paper's units), the ROS nodes convert to SI; move
//! goals alone work in SI (metres and seconds, as the action gives them: the law needs no scale).

pub mod mode;
pub mod move_goal;
pub mod period;
pub mod switch;
pub mod velocity;
