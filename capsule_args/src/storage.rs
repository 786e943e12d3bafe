//! The recording's storage flags, shared by `capsule_recorder`, `capsule_plant` (in-process
//! recording) and `capsule simulate --record`.

use crate::ranges;
use capsule_record::{BagOptions, ChunkCompression};

/// Longest split duration \[s\] (`--max-bag-duration`), as nanoseconds it still fits a `u64`.
const MAX_BAG_DURATION_S: f64 = 1e9;

/// How a recording is stored, as rosbag2 users configure it.
#[derive(Debug, Clone, clap::Args)]
pub struct StorageArgs {
    /// Chunk compression: none, zstd, zstd_fast, zstd_small or lz4 (rosbag2's MCAP presets)
    #[arg(long, default_value = "none", value_parser = parse_compression)]
    pub compression: ChunkCompression,
    /// Split the recording into NAME/NAME_0.mcap, NAME_1.mcap, ... with a rosbag2
    /// metadata.yaml, starting the next file at about this many bytes
    #[arg(long, value_name = "BYTES", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_bag_size: Option<u64>,
    /// Split the same way once a file spans this many seconds of recorded time, (0, 1e9]
    #[arg(long, value_name = "S", value_parser = ranges::positive(MAX_BAG_DURATION_S))]
    pub max_bag_duration: Option<f64>,
}

fn parse_compression(s: &str) -> Result<ChunkCompression, String> {
    s.parse()
}

impl StorageArgs {
    /// The storage options (every flag was range-checked when parsed).
    pub fn options(&self) -> BagOptions {
        BagOptions {
            compression: self.compression,
            max_bytes: self.max_bag_size,
            max_duration_ns: self.max_bag_duration.map(|s| (s * 1e9) as u64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        storage: StorageArgs,
    }

    #[test]
    fn storage_flags_parse_and_refuse_what_means_nothing() {
        let cli = Cli::try_parse_from(["t", "--compression", "zstd", "--max-bag-duration", "2.5"])
            .unwrap_or_else(|e| panic!("{e}"));
        let o = cli.storage.options();
        assert_eq!(o.max_duration_ns, Some(2_500_000_000));
        assert_eq!(o.compression, ChunkCompression::Zstd { level: 0 });
        for bad in [
            ["--max-bag-duration", "nan"],
            ["--max-bag-duration", "0"],
            ["--max-bag-duration", "1e10"],
            ["--max-bag-size", "0"],
            ["--compression", "brotli"],
        ] {
            let args = ["t", bad[0], bad[1]];
            assert!(Cli::try_parse_from(args).is_err(), "{bad:?} accepted");
        }
    }
}
