//! The `main` of a node binary around its node: logging to stderr, `--check`, the node's
//! future on a single-threaded runtime pinned to `--cpu-affinity`, and the exit status with the
//! error chain on one line.

use crate::error::{BoxError, Context as _, NodeError, Result};
use crate::{
    affinity::{self, CpuList},
    middleware::Middleware,
    ros_options::RosOptions,
};

/// Sets up tracing to stderr (`RUST_LOG` filters; default `info` with RustDDS's shutdown noise off).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new("info,rustdds=off,ros2_client=error")
    });
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(ansi)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Runs a node's future on a single-threaded tokio runtime (the thread that calls this), its
/// threads (and DDS's, started from them) pinned to `cpus` if given. One runtime thread: a
/// sample that DDS's thread hands over wakes that thread directly, where a multi-threaded
/// runtime wakes whichever worker is idle, often on the other CPU (docs/ros.md, lock-step).
pub fn block_on<T, E, F>(cpus: Option<&CpuList>, fut: F) -> Result<T, E>
where
    E: From<NodeError>,
    F: std::future::Future<Output = Result<T, E>>,
{
    block_on_with(cpus, &Middleware::Dds, fut)
}

/// [`block_on`] on the runtime `middleware` needs ([`Middleware::runtime`]).
pub fn block_on_with<T, E, F>(
    cpus: Option<&CpuList>,
    middleware: &Middleware,
    fut: F,
) -> Result<T, E>
where
    E: From<NodeError>,
    F: std::future::Future<Output = Result<T, E>>,
{
    if let Some(list) = cpus {
        affinity::pin_process(list).with_context(|| format!("--cpu-affinity {list}"))?;
    }
    middleware
        .runtime()
        .enable_all()
        .build()
        .context("cannot start the tokio runtime")?
        .block_on(fut)
}

/// Prints an error chain as one line (`NAME: error: what: why: ...`) and maps it to exit
/// status 2.
pub fn exit_code<E: Into<BoxError>>(name: &str, result: Result<(), E>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            let e: BoxError = e.into();
            eprintln!("{name}: error: {}", crate::error::chain(&*e));
            std::process::ExitCode::from(2)
        }
    }
}

/// The `main` of a node binary: with `--check` (`check`), prints `NAME: ok: SETTINGS` and
/// what `would` says about the options, and exits; otherwise `run`s the node. Either way an
/// error (of `built` or the run) is printed by [`exit_code`].
pub fn node_main<O, E: Into<BoxError>>(
    name: &str,
    check: bool,
    built: Result<(RosOptions, O), E>,
    would: impl FnOnce(&O) -> String,
    run: impl FnOnce(RosOptions, O) -> Result<(), E>,
) -> std::process::ExitCode {
    let result = built.and_then(|(settings, opts)| {
        if check {
            println!("{name}: ok: {}{}", settings.describe(), would(&opts));
            return Ok(());
        }
        run(settings, opts)
    });
    exit_code(name, result)
}

/// [`node_main`] for a node that is one future: run on [`block_on`]'s runtime, pinned to the
/// node's `--cpu-affinity`.
pub fn async_node_main<O, E, F>(
    name: &str,
    check: bool,
    built: Result<(RosOptions, O), E>,
    would: impl FnOnce(&O) -> String,
    run: impl FnOnce(RosOptions, O) -> F,
) -> std::process::ExitCode
where
    E: Into<BoxError> + From<NodeError>,
    F: std::future::Future<Output = Result<()>>,
{
    node_main(name, check, built, would, |settings, opts| {
        let (cpus, middleware) = (settings.cpu_affinity.clone(), settings.middleware.clone());
        Ok(block_on_with(
            cpus.as_ref(),
            &middleware,
            run(settings, opts),
        )?)
    })
}
