//! The capsule's control law, without ROS or I/O: the harmonic drive plus the position feedback
//! `u = k_p |x2 - x1|` of Liu et al. 2014 (eq. 2-3).
//!
//! Everything here is non-dimensional (the paper's units); the ROS nodes convert to SI.

pub mod law;
pub mod mode;
pub mod switch;
pub mod velocity;

pub use law::FeedbackLaw;
