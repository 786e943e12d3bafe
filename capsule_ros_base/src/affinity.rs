//! `--cpu-affinity`: keep a node's threads on chosen CPUs (as ros2_control's `cpu_affinity`).
//!
//! Why a node wants it: a sample costs each node about three thread wake-ups (DDS's event-loop
//! thread receives, the node thread computes, DDS's thread sends), and a wake-up that crosses
//! CPUs costs an inter-processor interrupt, on a virtual machine a VM exit. Plant and controller
//! sharing one CPU wake each other without one (figures: docs/ros.md).

use std::{fmt, str::FromStr};

use nix::sched::{sched_getaffinity, sched_setaffinity, CpuSet};
use nix::unistd::Pid;

/// Why a CPU list was refused.
#[derive(Debug, thiserror::Error)]
pub enum AffinityError {
    /// Not a list like `0`, `0,2` or `1-3`.
    #[error("{0:?} is not a CPU list (expected e.g. 0, 0,2 or 1-3): {1}")]
    Syntax(String, &'static str),
    /// A CPU this process may not run on.
    #[error("CPU {cpu} is not available to this process (allowed: {allowed})")]
    NotAllowed {
        /// The CPU asked for.
        cpu: usize,
        /// The CPUs the process may use, as a list.
        allowed: CpuList,
    },
    /// The kernel refused the call.
    #[error("{0}: {1}")]
    Os(&'static str, nix::Error),
}

/// A set of CPU numbers, written like `taskset -c` and `/proc/*/status`'s `Cpus_allowed_list`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuList(Vec<usize>);

impl CpuList {
    /// The CPUs, ascending, each once.
    pub fn cpus(&self) -> &[usize] {
        &self.0
    }
}

impl FromStr for CpuList {
    type Err = AffinityError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why| AffinityError::Syntax(s.to_string(), why);
        let mut cpus = Vec::new();
        for part in s.split(',').map(str::trim) {
            let (lo, hi) = part.split_once('-').unwrap_or((part, part));
            let lo: usize = lo.trim().parse().map_err(|_| bad("not a CPU number"))?;
            let hi: usize = hi.trim().parse().map_err(|_| bad("not a CPU number"))?;
            if lo > hi {
                return Err(bad("a range must go upwards"));
            }
            if hi >= CpuSet::count() {
                return Err(bad("CPU number beyond what the kernel's CPU set holds"));
            }
            cpus.extend(lo..=hi);
        }
        cpus.sort_unstable();
        cpus.dedup();
        Ok(CpuList(cpus))
    }
}

impl fmt::Display for CpuList {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // compact ranges: 0-3,6
        let mut i = 0;
        while i < self.0.len() {
            let mut j = i;
            while j + 1 < self.0.len() && self.0[j + 1] == self.0[j] + 1 {
                j += 1;
            }
            if i > 0 {
                f.write_str(",")?;
            }
            match j - i {
                0 => write!(f, "{}", self.0[i])?,
                _ => write!(f, "{}-{}", self.0[i], self.0[j])?,
            }
            i = j + 1;
        }
        Ok(())
    }
}

/// The CPUs this process may run on now.
pub fn allowed() -> Result<CpuList, AffinityError> {
    let set = sched_getaffinity(Pid::from_raw(0))
        .map_err(|e| AffinityError::Os("sched_getaffinity", e))?;
    Ok(CpuList(
        (0..CpuSet::count())
            .filter(|&c| set.is_set(c).unwrap_or(false))
            .collect(),
    ))
}

/// Refuses a list naming a CPU outside `allowed`.
pub fn check(list: &CpuList, allowed: &CpuList) -> Result<(), AffinityError> {
    match list.0.iter().find(|c| !allowed.0.contains(c)) {
        Some(&cpu) => Err(AffinityError::NotAllowed {
            cpu,
            allowed: allowed.clone(),
        }),
        None => Ok(()),
    }
}

/// Pins the calling thread, and so every thread it starts afterwards, to `list`. Call it before
/// the runtime and DDS start their threads.
pub fn pin_process(list: &CpuList) -> Result<(), AffinityError> {
    check(list, &allowed()?)?;
    let mut set = CpuSet::new();
    for &c in &list.0 {
        set.set(c).map_err(|e| AffinityError::Os("CPU set", e))?;
    }
    sched_setaffinity(Pid::from_raw(0), &set).map_err(|e| AffinityError::Os("sched_setaffinity", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn list(s: &str) -> CpuList {
        s.parse().unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    #[test]
    fn lists_parse_like_taskset_and_print_compactly() {
        assert_eq!(list("0").cpus(), &[0]);
        assert_eq!(list("3, 1-2,2").cpus(), &[1, 2, 3]);
        assert_eq!(list("0-3,6,8-9").to_string(), "0-3,6,8-9");
        for bad in ["", "x", "1-", "3-1", "0,,1", "-1", "1000000"] {
            assert!(bad.parse::<CpuList>().is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn cpus_outside_the_allowed_set_are_named() {
        let e = check(&list("0,5"), &list("0-1")).map(|_| ()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "CPU 5 is not available to this process (allowed: 0-1)"
        );
        assert!(check(&list("1"), &list("0-1")).is_ok());
    }

    #[test]
    fn this_process_may_run_somewhere() -> Result<(), AffinityError> {
        assert!(!allowed()?.cpus().is_empty());
        Ok(())
    }
}
