//! Work off the interpreter: the GIL released, the work on its own thread, and the calling thread
//! checking Python's signals while it waits, so that Ctrl-C (Python's `SIGINT` handler raising
//! `KeyboardInterrupt`) sets a cancel flag the work looks at between pieces of work.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How often the waiting thread checks for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);

/// Runs `work(cancel)` with the GIL released; `cancel` is set once Python has a pending signal
/// that raised (Ctrl-C). Returns the work's result and the signal's exception, if any. Signals are
/// seen only on the main thread (as in Python itself); elsewhere the work runs to its end.
pub fn run<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&AtomicBool) -> T + Send,
) -> (T, Option<PyErr>) {
    let cancel = AtomicBool::new(false);
    let mut raised = None;
    let out = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel();
            let cancel = &cancel;
            let handle = s.spawn(move || {
                let out = work(cancel);
                // the receiver waits until this arrives or the thread ends
                let _ = tx.send(());
                out
            });
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => break,
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if raised.is_none() {
                            if let Err(e) = Python::attach(|py| py.check_signals()) {
                                raised = Some(e);
                                cancel.store(true, Ordering::SeqCst);
                            }
                        }
                    }
                }
            }
            handle.join()
        })
    });
    match out {
        Ok(v) => (v, raised),
        // a panic in the work: carry it on in this thread, as if it had happened here
        Err(p) => std::panic::resume_unwind(p),
    }
}
