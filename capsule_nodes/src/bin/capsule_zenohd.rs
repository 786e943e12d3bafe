//! `capsule_zenohd`: a Zenoh router for the nodes on Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`),
//! for users without ROS 2's `ros2 run rmw_zenoh_cpp rmw_zenohd`: rmw_zenohd's settings (router
//! mode on port 7447, no multicast scouting, gossip, timestamps), listening on loopback only
//! unless `--listen` says otherwise; `ZENOH_ROUTER_CONFIG_URI` and `ZENOH_CONFIG_OVERRIDE` as
//! rmw_zenohd reads them. Runs until SIGINT/SIGTERM.

use anyhow::{Context as _, Result};
use capsule_ros_base::node_main;
use clap::Parser;

/// A Zenoh router as rmw_zenoh_cpp's rmw_zenohd runs one.
#[derive(Debug, Parser)]
#[command(name = "capsule_zenohd", version)]
struct Cli {
    /// Where the router listens (a Zenoh endpoint)
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    listen: String,
    /// Print the configuration (JSON) and exit
    #[arg(long)]
    check: bool,
}

/// rmw_zenohd's router settings (`DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5`) that differ from
/// Zenoh's defaults, as configuration keys and JSON5 values.
const ROUTER: [(&str, &str); 4] = [
    ("mode", "\"router\""),
    ("scouting/multicast/enabled", "false"),
    ("scouting/gossip/enabled", "true"),
    ("timestamping/enabled", "true"),
];

fn config(cli: &Cli) -> Result<zenoh::Config> {
    let get = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
    let mut config = match get("ZENOH_ROUTER_CONFIG_URI") {
        Some(path) => zenoh::Config::from_file(&path)
            .map_err(|e| anyhow::anyhow!("ZENOH_ROUTER_CONFIG_URI={path}: {e}"))?,
        None => {
            let mut config = zenoh::Config::default();
            for (key, value) in ROUTER {
                config
                    .insert_json5(key, value)
                    .map_err(|e| anyhow::anyhow!("the router's {key}={value}: {e}"))?;
            }
            let listen = serde_json::to_string(&[&cli.listen])?;
            config
                .insert_json5("listen/endpoints", &listen)
                .map_err(|e| anyhow::anyhow!("--listen {}: {e}", cli.listen))?;
            config
        }
    };
    if let Some(overrides) = get("ZENOH_CONFIG_OVERRIDE") {
        capsule_ros_base::zenoh_session::apply_overrides(&mut config, &overrides)?;
    }
    Ok(config)
}

async fn run(config: zenoh::Config) -> Result<()> {
    // the signal handlers first (polling the future once installs them): zenoh::open blocks
    // this thread while it opens (its port already listening), and a router stopped meanwhile
    // must stop cleanly instead of dying of the signal
    let sig = capsule_ros_base::signals::shutdown_signal();
    tokio::pin!(sig);
    if let std::task::Poll::Ready(sig) = futures::poll!(&mut sig) {
        tracing::info!("{}: stopped while starting", sig?);
        return Ok(());
    }
    let session = zenoh::open(config)
        .await
        .map_err(|e| anyhow::anyhow!("cannot start the router: {e}"))?;
    tracing::info!("router {} up", session.zid());
    let sig = sig.await?;
    tracing::info!("{sig}: shutting down");
    session
        .close()
        .await
        .map_err(|e| anyhow::anyhow!("closing the router: {e}"))
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let cli = Cli::parse();
    let result = config(&cli).and_then(|config| {
        if cli.check {
            println!("capsule_zenohd: ok: {}", config);
            return Ok(());
        }
        // zenoh's runtime needs a multi-threaded tokio runtime
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .context("cannot start the tokio runtime")?
            .block_on(run(config))
    });
    node_main::exit_code("capsule_zenohd", result)
}
