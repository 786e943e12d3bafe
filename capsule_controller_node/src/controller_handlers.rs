//! What the controller's loop does with each input apart from DDS ([`Handlers`]): the core's
//! decisions, the parameters kept in step, which plant is served, and the logs. The DDS side is
//! [`crate::controller_endpoints`]; composed with the plant, the plant's loop calls the same
//! [`Handlers::on_state`] on its own thread.

use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use capsule_hardware::throttle::Throttle;
use capsule_msgs::names::topics;
use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, SetModeRequest, SetModeResponse,
};
use capsule_plant::number_text::short;
use capsule_ros_base::{clock::RosClock, param_services::ParamHandle, ros_options::RosOptions};
use ros2_client::Gid;
use tracing::{info, warn};

use crate::{
    controller_core::ControllerCore,
    controller_diagnostics::ControllerDiag,
    controller_params::LiveSync,
    plant_identity::{PlantIdentity, Source},
};

/// The handlers, also after a panic elsewhere (the link names it and answers nothing more).
pub(crate) fn lock(h: &Mutex<Handlers>) -> MutexGuard<'_, Handlers> {
    h.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// What the loop does with each input, apart from DDS: the core's decisions, the parameters
/// kept in step, which plant is served, and the logs.
pub(crate) struct Handlers {
    pub(crate) core: ControllerCore,
    pub(crate) params: LiveSync,
    plants: PlantIdentity<Gid>,
    pub(crate) clock: RosClock,
    /// The steady clock of the watchdog and the plant identity.
    start: Instant,
    pub(crate) diag: ControllerDiag,
    pub(crate) node_name: String,
    /// The state topic as resolved, for the logs.
    state_topic: String,
    second_plant_log: Throttle,
    ignored_log: Throttle,
}

impl Handlers {
    pub(crate) fn new(
        core: ControllerCore,
        handle: ParamHandle,
        clock: RosClock,
        settings: &RosOptions,
    ) -> Handlers {
        Handlers {
            params: LiveSync::new(handle, &core),
            core,
            plants: PlantIdentity::new(PlantIdentity::<Gid>::DEFAULT_HANDOVER_S),
            clock,
            start: Instant::now(),
            diag: ControllerDiag::default(),
            node_name: settings.node_name.clone(),
            state_topic: settings.resolve_name(topics::STATE),
            second_plant_log: Throttle::default(),
            ignored_log: Throttle::default(),
        }
    }

    fn steady(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The status now.
    pub(crate) fn status(&self) -> ControllerStatus {
        self.core.status(self.clock.now())
    }

    /// Whether a sample from `publisher` is the plant's to answer (a new plant is adopted, a
    /// second one ignored).
    fn is_our_plant(&mut self, state: &CapsuleState, publisher: Gid) -> bool {
        match self.plants.observe(publisher, self.steady()) {
            Source::Current | Source::Adopted(None) => true,
            Source::Adopted(Some(silent)) => {
                self.core.new_plant();
                info!("a new plant publishes (seq {}) after {silent:.3} s without the last one: commanding it from now on", state.seq);
                true
            }
            Source::Second => {
                if self.second_plant_log.tick() {
                    warn!(
                        "A SECOND PLANT publishes {} (seq {}) while the first does: both apply every command; its samples are ignored ({} so far)",
                        self.state_topic,
                        state.seq,
                        self.plants.ignored()
                    );
                }
                false
            }
        }
    }

    /// A state sample: the command to send and, after an attractor-switch event, the status
    /// to publish; `None` for a sample not answered.
    pub(crate) fn on_state(
        &mut self,
        state: &CapsuleState,
        publisher: Gid,
    ) -> Option<(ActuatorForce, Option<ControllerStatus>)> {
        if !self.is_our_plant(state, publisher) {
            return None;
        }
        let core = &mut self.core;
        let was = core.commanding();
        let refused = core.plant_refuses();
        let ignored = core.ignored_samples();
        let answer = core.on_state(state, self.start.elapsed().as_secs_f64());
        if core.ignored_samples() > ignored && self.ignored_log.tick() {
            let why = core
                .ignored_why()
                .map(|w| w.to_string())
                .unwrap_or_default();
            warn!(
                "state seq {} not used ({why}): {} so far",
                state.seq,
                core.ignored_samples()
            );
        }
        let cmd = answer?;
        if !was {
            info!("state fresh at seq {}: commanding", state.seq);
        }
        match (refused, core.plant_refuses()) {
            (false, true) => warn!(
                "the plant does not take our commands ({} refused so far, command_stale {}): not in control",
                state.rejected_commands, state.command_stale
            ),
            (true, false) => info!("the plant takes our commands again (seq {})", state.seq),
            _ => {}
        }
        if !core.take_switch_event() {
            return Some((cmd, None));
        }
        let st = self.status();
        info!(
            "attractor switch: {} (try {}, orbit period {}, k_p {})",
            self.core
                .attractor_switch()
                .map_or("?", |s| s.state().name()),
            st.switch_tries,
            st.orbit_period,
            st.gain
        );
        self.params.push(&self.core);
        Some((cmd, Some(st)))
    }

    /// A set_mode request: the answer (the core's), logged.
    pub(crate) fn on_request(&mut self, req: &SetModeRequest) -> SetModeResponse {
        let resp = self.core.set_mode(req);
        if resp.accepted {
            info!("set_mode accepted: {}", resp.reason);
        } else {
            warn!(
                "set_mode refused (mode {} gain {}): {}",
                req.mode,
                short(req.gain),
                resp.reason
            );
        }
        resp
    }

    /// The status period: the core's own mode changes to the parameters, the watchdog; the
    /// status to publish.
    pub(crate) fn on_tick(&mut self) -> ControllerStatus {
        self.params.push(&self.core);
        if self.core.check_stale(self.steady()) {
            warn!("state stale (no sample for the timeout; plant gone?): stopped commanding");
        }
        self.status()
    }
}
