//! The plant node's hardware interface, with no DDS, no async runtime and no node in it: what a
//! driver for your own capsule depends on.
//!
//! - [`interface`]: the [`CapsuleHardware`] trait (ros2_control's shape, in SI), its errors and
//!   readings, and [`Ready`], how a device that paces itself wakes whoever reads it
//! - [`sample`]: the SI [`Sample`] a `read` returns
//! - [`sim`]: the simulator of `capsule_plant` behind the trait
//! - [`mock`]: a free mass behind the trait, for tests and as the smallest example
//! - [`serial_driver`]: a device speaking `capsule_device`'s protocol on a serial line
//! - [`latency`]: latency percentiles in constant memory; [`throttle`]: rate-limited logs of
//!   events that repeat once per sample

#![warn(missing_docs)]

pub mod interface;
pub mod latency;
pub mod mock;
pub mod sample;
pub mod serial_driver;
pub mod sim;
pub mod throttle;

pub use interface::{CapsuleHardware, HardwareError, Reading, Ready, SourceHealth, Stopper};
pub use sample::Sample;
