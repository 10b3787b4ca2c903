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
use crate::error::{ConfigError, Result, TrackingError};
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

/// One allow-list entry: an address (`192.168.0.20`) or a CIDR block (`10.9.0.0/16`,
/// `fe80::/10`), written as text in the TOML.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AllowEntry {
    /// The network's address (bits past the prefix are ignored).
    pub addr: IpAddr,
    /// Leading bits that must match (32 or 128 for a single address).
    pub prefix: u8,
}

/// Why an allow-list entry does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AllowEntryError {
    /// The address part is no IPv4 or IPv6 address.
    #[error("`{0}` is not an IP address")]
    Address(String),
    /// The prefix length is not a number within the address's bits.
    #[error("prefix `/{prefix}` is not 0 to {bits}")]
    Prefix {
        /// The prefix as written.
        prefix: String,
        /// The address family's bits (32 or 128).
        bits: u8,
    },
}

/// An IPv4-mapped IPv6 address as its IPv4 address (a dual-stack socket's peers).
fn canonical(ip: IpAddr) -> IpAddr {
    match ip {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
        v4 => v4,
    }
}

impl AllowEntry {
    /// Whether `ip` lies in this block (an IPv4-mapped IPv6 peer counts as IPv4).
    pub fn contains(&self, ip: IpAddr) -> bool {
        fn prefix_eq(a: &[u8], b: &[u8], bits: u8) -> bool {
            let (whole, rest) = (usize::from(bits / 8), bits % 8);
            if a[..whole] != b[..whole] {
                return false;
            }
            rest == 0 || {
                let mask = 0xffu8 << (8 - rest);
                a[whole] & mask == b[whole] & mask
            }
        }
        match (canonical(self.addr), canonical(ip)) {
            (IpAddr::V4(net), IpAddr::V4(ip)) => {
                prefix_eq(&net.octets(), &ip.octets(), self.prefix.min(32))
            }
            (IpAddr::V6(net), IpAddr::V6(ip)) => {
                prefix_eq(&net.octets(), &ip.octets(), self.prefix.min(128))
            }
            _ => false,
        }
    }
}

impl std::str::FromStr for AllowEntry {
    type Err = AllowEntryError;
    fn from_str(s: &str) -> std::result::Result<Self, AllowEntryError> {
        let (ip, prefix) = match s.split_once('/') {
            Some((ip, p)) => (ip, Some(p)),
            None => (s, None),
        };
        let addr: IpAddr = ip
            .trim()
            .parse()
            .map_err(|_| AllowEntryError::Address(ip.to_string()))?;
        let bits = if addr.is_ipv4() { 32 } else { 128 };
        let prefix = match prefix {
            None => bits,
            Some(p) => p
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|&n| n <= bits)
                .ok_or_else(|| AllowEntryError::Prefix {
                    prefix: p.to_string(),
                    bits,
                })?,
        };
        Ok(Self { addr, prefix })
    }
}

impl std::fmt::Display for AllowEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let bits = if self.addr.is_ipv4() { 32 } else { 128 };
        if self.prefix == bits {
            write!(f, "{}", self.addr)
        } else {
            write!(f, "{}/{}", self.addr, self.prefix)
        }
    }
}

impl Serialize for AllowEntry {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for AllowEntry {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

impl From<IpAddr> for AllowEntry {
    fn from(addr: IpAddr) -> Self {
        let prefix = if addr.is_ipv4() { 32 } else { 128 };
        Self { addr, prefix }
    }
}

/// Who may feed a listening source: the allow-list and whether loopback peers pass
/// regardless of it (see [`TrackingConfig::allow`] and
/// [`TrackingConfig::allow_loopback`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PeerPolicy {
    /// The entries (empty: any peer).
    pub allow: Vec<AllowEntry>,
    /// Loopback peers (127.0.0.0/8, ::1) pass even when not listed.
    pub allow_loopback: bool,
}

impl PeerPolicy {
    /// Whether `peer` may feed the source: any peer when the list is empty; else a peer
    /// in one of its blocks, or a loopback peer when `allow_loopback` is set.
    pub fn allows(&self, peer: IpAddr) -> bool {
        self.allow.is_empty()
            || (self.allow_loopback && canonical(peer).is_loopback())
            || self.allow.iter().any(|e| e.contains(peer))
    }
}

/// Whether `peer` is on the allow-list (an empty list allows every peer), loopback
/// not excepted. An IPv4-mapped IPv6 address matches its IPv4 entry.
pub fn peer_allowed(allow: &[AllowEntry], peer: IpAddr) -> bool {
    allow.is_empty() || allow.iter().any(|e| e.contains(peer))
}

/// What a listening source expects of the tracker before it lets a peer feed the
/// session (`[expect]`). A peer is *plausible* once it has sent, within
/// `identify_ms` of connecting (and after its hello, with a `secret`), enough
/// decodable DTrack2 frames that each carry every device in `devices`, at a frame
/// rate that fits `rate_hz`. One that is not is closed, counted and logged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExpectConfig {
    /// Devices every frame must carry (`wand0`, `body0`); empty: any frame will do.
    pub devices: Vec<String>,
    /// The tracker's frame rate, Hz (0: not checked). Checked on the frames' `ts`
    /// steps when they carry one (their median must lie within half to twice
    /// `1 / rate_hz`), else on the arrival count (at least half the rate).
    pub rate_hz: f64,
    /// Frames needed before a peer counts as the tracker (at least 1).
    pub frames: usize,
    /// How long a new peer has to become plausible, ms.
    pub identify_ms: u64,
}

impl Default for ExpectConfig {
    fn default() -> Self {
        Self {
            devices: Vec::new(),
            rate_hz: 0.0,
            frames: 1,
            identify_ms: 1000,
        }
    }
}

impl ExpectConfig {
    /// The devices, parsed (`wand0` -> `DeviceId::Wand(0)`).
    pub fn device_ids(&self) -> Result<Vec<crate::DeviceId>> {
        self.devices.iter().map(|d| d.parse()).collect()
    }

    /// The frames needed: the configured count, and with a rate, enough for the rate
    /// check (3).
    pub fn frames_needed(&self) -> usize {
        let base = self.frames.max(1);
        if self.rate_hz > 0.0 {
            base.max(3)
        } else {
            base
        }
    }
}

/// What a peer of a listening source with a secret sends first: `wandsculpt-hello `,
/// the secret, and a line end.
pub const HELLO_PREFIX: &str = "wandsculpt-hello ";
/// The longest secret ([`crate::config::valid_secret`]).
pub const MAX_SECRET: usize = 256;
/// The longest hello line read (prefix, secret, CR/LF).
pub const MAX_HELLO: usize = HELLO_PREFIX.len() + MAX_SECRET + 2;
/// The hello line for `secret` (what `replay --connect --secret-file` writes first).
pub fn hello_line(secret: &str) -> Vec<u8> {
    format!("{HELLO_PREFIX}{secret}\r\n").into_bytes()
}

/// Why a hello line is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HelloError {
    /// It does not start with [`HELLO_PREFIX`].
    #[error("no hello line (`{HELLO_PREFIX}<secret>`)")]
    NoHello,
    /// The secret does not match.
    #[error("wrong secret")]
    WrongSecret,
    /// A secret file's first line is not a secret that can be sent.
    #[error("the secret must be 1 to {MAX_SECRET} printable characters without spaces")]
    BadSecret,
}

/// The hello line for a secret file's text: its first line, trimmed, must be a
/// [valid secret](valid_secret). What `wandtrack --secret-file` and
/// `replay --secret-file` send first.
pub fn hello_from_secret_text(text: &str) -> std::result::Result<Vec<u8>, HelloError> {
    let secret = text.lines().next().unwrap_or("").trim();
    if valid_secret(secret) {
        Ok(hello_line(secret))
    } else {
        Err(HelloError::BadSecret)
    }
}

/// Checks one hello line (with or without its CR/LF) against `secret`, in time that
/// depends only on the lengths.
pub fn check_hello(line: &[u8], secret: &[u8]) -> std::result::Result<(), HelloError> {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let given = line
        .strip_prefix(HELLO_PREFIX.as_bytes())
        .ok_or(HelloError::NoHello)?;
    if constant_time_eq(given, secret) {
        Ok(())
    } else {
        Err(HelloError::WrongSecret)
    }
}

/// Whether two byte strings are equal, in time that depends on their lengths only
/// (every byte is compared, no early exit).
pub fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    let mut diff = a.len() ^ b.len();
    for i in 0..a.len().max(b.len()) {
        let x = a.get(i).copied().unwrap_or(0);
        let y = b.get(i).copied().unwrap_or(0);
        diff |= usize::from(std::hint::black_box(x ^ y));
    }
    diff == 0
}

/// Whether a secret can be sent on the hello line: 1 to 256 printable ASCII bytes
/// without spaces.
pub fn valid_secret(s: &str) -> bool {
    (1..=MAX_SECRET).contains(&s.len()) && s.bytes().all(|b| b.is_ascii_graphic())
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
    /// Peer addresses or CIDR blocks (`"10.9.9.9"`, `"10.9.0.0/16"`) that may feed a
    /// `tcp-listen` or `udp` source; connections and datagrams from any other address
    /// are refused and logged, and never touch the session. Empty (the default) allows
    /// any peer.
    pub allow: Vec<AllowEntry>,
    /// With an `allow` list, loopback peers (local processes: `replay --connect`, a
    /// local tracker emulator) pass too (the default); `false` refuses them unless
    /// listed.
    pub allow_loopback: bool,
    /// A shared secret: a peer of a `tcp-listen` source must first send the line
    /// `wandsculpt-hello <secret>` (within `[expect] identify_ms`); a wrong or missing
    /// hello closes the connection, counted and logged. Compared in constant time.
    pub secret: Option<String>,
    /// What the tracker sends (`[expect]`): a listening peer that sends nothing
    /// plausible in time is dropped.
    pub expect: ExpectConfig,
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
            allow_loopback: true,
            secret: None,
            expect: ExpectConfig::default(),
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
        let cfg: Self = toml::from_str(text)
            .map_err(|e| TrackingError::Config(ConfigError::Toml(Box::new(e))))?;
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
        toml::to_string(self)
            .map_err(|e| TrackingError::Config(ConfigError::TomlWrite(Box::new(e))))
    }

    /// Checks ranges and the calibration.
    pub fn validate(&self) -> Result<()> {
        let bad = |e: ConfigError| Err(TrackingError::Config(e));
        if self.lost_after_ms == 0 || self.read_timeout_ms == 0 {
            return bad(ConfigError::Timeouts);
        }
        if self.reconnect_min_ms == 0 || self.reconnect_max_ms < self.reconnect_min_ms {
            return bad(ConfigError::Reconnect);
        }
        if self.max_connections == 0 {
            return bad(ConfigError::MaxConnections);
        }
        if self.secret.as_ref().is_some_and(|s| !valid_secret(s)) {
            return bad(ConfigError::Secret);
        }
        let e = &self.expect;
        if !(e.rate_hz.is_finite() && e.rate_hz >= 0.0) || e.identify_ms == 0 || e.frames > 10_000 {
            return bad(ConfigError::Expect);
        }
        e.device_ids()?;
        let l = self.limits;
        if l.max_line < 64 || l.max_frame < l.max_line || l.max_devices == 0 {
            return bad(ConfigError::Limits);
        }
        self.filter.validate()?;
        self.calibration.validate()
    }

    /// Whether `peer` may feed a listening source (see [`TrackingConfig::allow`] and
    /// [`TrackingConfig::allow_loopback`]).
    pub fn allows(&self, peer: IpAddr) -> bool {
        self.peer_policy().allows(peer)
    }

    /// The allow-list and loopback rule of listening sources.
    pub fn peer_policy(&self) -> PeerPolicy {
        PeerPolicy {
            allow: self.allow.clone(),
            allow_loopback: self.allow_loopback,
        }
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
