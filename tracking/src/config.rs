//! Tracking configuration, read from TOML (documented in
//! `docs/formats/tracking-config.md`).
//!
//! ```
//! use tracking::config::{TrackingConfig, SourceConfig};
//! let cfg = TrackingConfig::from_toml_str(r#"
//!     lost_after_ms = 150
//!     [[source]]
//!     kind = "udp"
//!     [filter]
//!     enabled = false
//! "#).unwrap();
//! assert_eq!(cfg.sources[0], SourceConfig::Udp { addr: "127.0.0.1:5000".parse().unwrap() });
//! assert!(!cfg.filter.enabled);
//! ```

use crate::calibration::Calibration;
use crate::dtrack::DecoderLimits;
use crate::error::{Result, TrackingError};
use crate::filter::FilterConfig;
use serde::{Deserialize, Serialize};
use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Default UDP port of DTrack2 output.
pub const DEFAULT_UDP_PORT: u16 = 5000;

fn udp_default() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], DEFAULT_UDP_PORT))
}

fn tcp_default() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 5001))
}

fn baud_default() -> u32 {
    115_200
}

fn buttons_default() -> u8 {
    6
}

/// One input.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum SourceConfig {
    /// Listen for the tracking server to connect and push DTrack2 frames.
    TcpListen {
        /// Address to bind (default `127.0.0.1:5001`: loopback only).
        #[serde(default = "tcp_default")]
        addr: SocketAddr,
    },
    /// Connect out to a tracking server that listens.
    TcpConnect {
        /// The server's address.
        addr: SocketAddr,
    },
    /// Receive DTrack2 datagrams (default `127.0.0.1:5000`; use `0.0.0.0:5000` to
    /// accept a tracker on the network).
    Udp {
        /// Address to bind.
        #[serde(default = "udp_default")]
        addr: SocketAddr,
    },
    /// A serial wand (see [`crate::serial`]).
    Serial {
        /// Port path, e.g. `/dev/ttyUSB0`.
        port: String,
        /// Baud rate (default 115200).
        #[serde(default = "baud_default")]
        baud: u32,
        /// The wand id its records are merged as.
        #[serde(default)]
        wand_id: u32,
        /// Number of buttons it has (default 6).
        #[serde(default = "buttons_default")]
        button_count: u8,
    },
    /// DTrack2 ASCII frames over a serial line (a tracking server, or `replay --serve
    /// serial://...`, writing to a serial port or pseudo-terminal).
    SerialDtrack {
        /// Port path, e.g. `/dev/ttyUSB0`.
        port: String,
        /// Baud rate (default 115200).
        #[serde(default = "baud_default")]
        baud: u32,
    },
}

impl SourceConfig {
    /// A short description (`udp 127.0.0.1:5000`).
    pub fn describe(&self) -> String {
        match self {
            SourceConfig::TcpListen { addr } => format!("tcp-listen {addr}"),
            SourceConfig::TcpConnect { addr } => format!("tcp-connect {addr}"),
            SourceConfig::Udp { addr } => format!("udp {addr}"),
            SourceConfig::Serial { port, baud, .. } => format!("serial {port}@{baud}"),
            SourceConfig::SerialDtrack { port, baud } => format!("serial-dtrack {port}@{baud}"),
        }
    }
}

/// Whether `peer` is on the allow-list (an empty list allows every peer). An
/// IPv4-mapped IPv6 address matches its IPv4 entry.
pub fn peer_allowed(allow: &[IpAddr], peer: IpAddr) -> bool {
    let peer = match peer {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(peer, IpAddr::V4),
        v4 => v4,
    };
    allow.is_empty() || allow.contains(&peer)
}

/// Everything the tracking layer needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingConfig {
    /// The inputs (`[[source]]` tables).
    #[serde(rename = "source")]
    pub sources: Vec<SourceConfig>,
    /// A device is lost when its last tracked pose is older than this, ms.
    pub lost_after_ms: u64,
    /// A stream that completes no frame for this long is dropped (and reconnected), ms.
    pub read_timeout_ms: u64,
    /// First reconnect delay, ms (doubles up to `reconnect_max_ms`).
    pub reconnect_min_ms: u64,
    /// Longest reconnect delay, ms.
    pub reconnect_max_ms: u64,
    /// Most simultaneous connections a TCP listener accepts (1: one active connection
    /// per source; a further peer is refused and logged while it lasts).
    pub max_connections: usize,
    /// Peer addresses that may feed a `tcp-listen` or `udp` source; connections and
    /// datagrams from any other address are refused and logged, and never touch the
    /// session. Empty (the default) allows any peer.
    pub allow: Vec<IpAddr>,
    /// Decoder caps.
    pub limits: DecoderLimits,
    /// The One Euro filter.
    pub filter: FilterConfig,
    /// Tracker-to-display calibration and tip offsets.
    pub calibration: Calibration,
    /// Record every raw frame to this pose log, if set.
    pub record: Option<PathBuf>,
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            sources: Vec::new(),
            lost_after_ms: 100,
            read_timeout_ms: 2000,
            reconnect_min_ms: 100,
            reconnect_max_ms: 2000,
            max_connections: 1,
            allow: Vec::new(),
            limits: DecoderLimits::default(),
            filter: FilterConfig::default(),
            calibration: Calibration::default(),
            record: None,
        }
    }
}

impl TrackingConfig {
    /// Parses and validates TOML.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let cfg: Self = toml::from_str(text).map_err(|e| TrackingError::Config(e.to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Reads and validates a TOML file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| TrackingError::io_path(path, e))?;
        Self::from_toml_str(&text)
    }

    /// The config as TOML.
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| TrackingError::Config(e.to_string()))
    }

    /// Checks ranges and the calibration.
    pub fn validate(&self) -> Result<()> {
        let bad = |s: &str| Err(TrackingError::Config(s.to_string()));
        if self.lost_after_ms == 0 || self.read_timeout_ms == 0 {
            return bad("lost_after_ms and read_timeout_ms must be > 0");
        }
        if self.reconnect_min_ms == 0 || self.reconnect_max_ms < self.reconnect_min_ms {
            return bad("need 0 < reconnect_min_ms <= reconnect_max_ms");
        }
        if self.max_connections == 0 {
            return bad("max_connections must be > 0");
        }
        let l = self.limits;
        if l.max_line < 64 || l.max_frame < l.max_line || l.max_devices == 0 {
            return bad("limits: need max_line >= 64, max_frame >= max_line, max_devices > 0");
        }
        self.filter.validate()?;
        self.calibration.validate()
    }

    /// Whether `peer` may feed a listening source (see [`TrackingConfig::allow`]).
    pub fn allows(&self, peer: IpAddr) -> bool {
        peer_allowed(&self.allow, peer)
    }

    /// `lost_after_ms` as a duration.
    pub fn lost_after(&self) -> Duration {
        Duration::from_millis(self.lost_after_ms)
    }

    /// `read_timeout_ms` as a duration.
    pub fn read_timeout(&self) -> Duration {
        Duration::from_millis(self.read_timeout_ms)
    }
}
