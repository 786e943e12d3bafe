//! The vibro-impact capsule of Liu, Pavlovskaia, Wiercigroch and Peng (2014), simulated exactly.
//!
//! A pure library (no ROS, no I/O): the model ([`model`]), its friction laws ([`friction`]), actuator
//! force laws ([`law`]), the event-driven simulator with three integration methods ([`solver`])
//! scene files ([`scene`]), the SI scale ([`physical`]), a prototype's sensor and actuator as
//! models ([`device`]), and numbers as messages write them ([`number_text`]).

mod choices;
pub mod device;
pub mod equations;
pub mod friction;
pub mod law;
pub mod model;
pub mod number_text;
pub mod physical;
mod roots;
pub mod scene;
pub mod solver;

pub use law::{ActuatorLaw, AffineLaw, ConstantForce, LawShape};
pub use model::{Capsule, Friction, Model, State};
pub use solver::{
    Event, EventKind, Method, Phase, Regime, SimError, Simulator, Snapshot, SolverConfig, Stop,
    Transition, Work,
};
