//! Transports: where tokio lives. TCP (listen or connect), UDP and serial inputs that
//! feed a [`Hub`], and paced senders for the simulator and for re-sending pose logs.
//!
//! Every input stamps frames with the hub's monotonic clock as soon as a read returns,
//! decodes all frames in that read, and applies them to the hub. Streams are dropped
//! (and, when connecting out, re-established with exponential backoff) when they
//! complete no frame within the read timeout (so a slow-loris sender cannot hold a
//! connection), and decoders cap line and frame sizes so memory stays bounded.
//!
//! Trust: anyone on the machine can open a loopback connection, so a listening source
//! keeps one active peer, and only a plausible one. A `tcp-listen` source accepts
//! every connection at once and identifies each concurrently (at most
//! [`MAX_CANDIDATES`] at a time): with a [`TrackingConfig::secret`] the peer must first
//! send its [hello line](hello_line) (compared in constant time), then it must send
//! decodable DTrack2 frames carrying the devices, at the rate, that
//! [`TrackingConfig::expect`] names, within `identify_ms` (1 s by default). The first
//! peer to do so becomes the source's connection (up to
//! [`TrackingConfig::max_connections`], 1 by default) and its frames, those read while
//! it was identified included, are applied; every other peer is closed, counted and
//! logged. So a squatter that connects first, or keeps reconnecting, sending nothing
//! or garbage, cannot lock the tracker out, and a second peer can neither press
//! buttons nor interleave frames. A `udp` source takes datagrams from one peer at a
//! time: peers are identified the same way (without a hello: a DTrack2 controller
//! cannot send one), and the first plausible one is the source's peer until it goes
//! quiet for the read timeout. With
//! [`TrackingConfig::allow`] set, connections and datagrams from any other address
//! (loopback excepted unless [`TrackingConfig::allow_loopback`] is false) are refused
//! before a byte is read. Refused peers are counted in
//! [`SourceStats::refused`](crate::hub::SourceStats) and never open, feed or close the
//! source, so they cannot end a session either.
//!
//! ```no_run
//! # async fn demo() -> tracking::Result<()> {
//! use tracking::config::{SourceConfig, TrackingConfig};
//! use tracking::transport::start;
//! let mut cfg = TrackingConfig::default();
//! cfg.sources.push(SourceConfig::Udp { addr: "127.0.0.1:5000".parse().unwrap() });
//! let running = start(&cfg).await?;
//! let wand = running.hub.watch(tracking::DeviceId::Wand(0));
//! # Ok(()) }
//! ```

pub use crate::config::{HELLO_PREFIX, HelloError, MAX_HELLO, MAX_SECRET, check_hello, hello_line};
use crate::config::{PeerPolicy, SourceConfig, TrackingConfig};
use crate::dtrack::{DTrackDecoder, Decoded, DecoderLimits};
use crate::error::{Result, TrackingError};
use crate::frame::DeviceId;
use crate::hub::{Hub, SourceId};
use crate::poselog::{PoseLogHeader, PoseLogWriter, RecordKind};
use crate::serial::SerialDecoder;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::Semaphore;
use tokio::task::JoinHandle;

/// Read buffer size: several frames per read.
const READ_BUF: usize = 64 * 1024;

/// Transport timing and caps (from [`TrackingConfig`]).
#[derive(Debug, Clone, Copy)]
pub struct TransportOptions {
    /// Decoder caps.
    pub limits: DecoderLimits,
    /// Drop a stream that completes no frame for this long.
    pub read_timeout: Duration,
    /// First reconnect delay.
    pub backoff_min: Duration,
    /// Longest reconnect delay.
    pub backoff_max: Duration,
    /// Most simultaneous connections per TCP listener.
    pub max_connections: usize,
}

/// Who a listening source admits, and how it tells the tracker (see the module docs).
#[derive(Debug)]
struct Admission {
    policy: PeerPolicy,
    secret: Option<Vec<u8>>,
    devices: Vec<DeviceId>,
    rate_hz: f64,
    frames: usize,
    identify: Duration,
}

type AllowList = Arc<Admission>;

impl Admission {
    fn new(config: &TrackingConfig) -> Result<Self> {
        Ok(Self {
            policy: config.peer_policy(),
            secret: config.secret.as_ref().map(|s| s.as_bytes().to_vec()),
            devices: config.expect.device_ids()?,
            rate_hz: config.expect.rate_hz,
            frames: config.expect.frames_needed(),
            identify: Duration::from_millis(config.expect.identify_ms),
        })
    }
}

/// Most peers of one listening source being identified at once; more are refused.
pub const MAX_CANDIDATES: usize = 64;
/// Most frames buffered from a peer while it is identified; more without becoming
/// plausible is a refusal.
pub const MAX_IDENTIFY_FRAMES: usize = 4096;

impl From<&TrackingConfig> for TransportOptions {
    fn from(c: &TrackingConfig) -> Self {
        Self {
            limits: c.limits,
            read_timeout: c.read_timeout(),
            backoff_min: Duration::from_millis(c.reconnect_min_ms),
            backoff_max: Duration::from_millis(c.reconnect_max_ms),
            max_connections: c.max_connections,
        }
    }
}

/// Running inputs: the hub plus the tasks feeding it (aborted on drop).
#[derive(Debug)]
pub struct Running {
    /// The merged state.
    pub hub: Hub,
    /// Bound local addresses of TCP listeners and UDP sockets, in config order
    /// (`None` for connect-out and serial sources).
    pub local_addrs: Vec<Option<SocketAddr>>,
    /// The source ids, in config order.
    pub sources: Vec<SourceId>,
    tasks: Vec<JoinHandle<()>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        for t in &self.tasks {
            t.abort();
        }
    }
}

/// Starts every source in the config plus the staleness watchdog, and the recorder
/// when `record` is set. Binding errors are returned; later I/O errors are retried.
pub async fn start(config: &TrackingConfig) -> Result<Running> {
    config.validate()?;
    start_with_hub(Hub::new(config), config).await
}

/// Like [`start`], onto an existing hub: subscribe to its events (and watch devices)
/// first, then start, and no early event is missed.
pub async fn start_with_hub(hub: Hub, config: &TrackingConfig) -> Result<Running> {
    config.validate()?;
    if let Some(path) = &config.record
        && !hub.is_recording()
    {
        let mut header = PoseLogHeader::new(
            config
                .sources
                .iter()
                .map(SourceConfig::describe)
                .collect::<Vec<_>>()
                .join(", "),
        );
        header.config = serde_json::to_value(config)?;
        header.calibration = serde_json::to_value(&config.calibration)?;
        hub.set_recorder(PoseLogWriter::create(path, &header)?);
    }
    let opts = TransportOptions::from(config);
    let allow: AllowList = Arc::new(Admission::new(config)?);
    let mut running = Running {
        hub: hub.clone(),
        local_addrs: Vec::new(),
        sources: Vec::new(),
        tasks: Vec::new(),
    };
    for spec in &config.sources {
        let src = hub.add_source(spec.describe());
        running.sources.push(src);
        let (addr, task) = match spec.clone() {
            SourceConfig::TcpListen { addr } => {
                let listener = TcpListener::bind(addr)
                    .await
                    .map_err(|e| TrackingError::io(addr.to_string(), e))?;
                let local = listener.local_addr().ok();
                (
                    local,
                    tokio::spawn(tcp_listen(hub.clone(), src, listener, opts, allow.clone())),
                )
            }
            SourceConfig::TcpConnect { addr } => (
                None,
                tokio::spawn(tcp_connect(hub.clone(), src, addr, opts)),
            ),
            SourceConfig::Udp { addr } => {
                let sock = UdpSocket::bind(addr)
                    .await
                    .map_err(|e| TrackingError::io(addr.to_string(), e))?;
                let local = sock.local_addr().ok();
                (
                    local,
                    tokio::spawn(udp(hub.clone(), src, sock, opts, allow.clone())),
                )
            }
            SourceConfig::Serial {
                port,
                baud,
                wand_id,
                button_count,
            } => (
                None,
                tokio::spawn(serial(
                    hub.clone(),
                    src,
                    port,
                    baud,
                    wand_id,
                    button_count,
                    opts,
                )),
            ),
            SourceConfig::SerialDtrack { port, baud } => (
                None,
                tokio::spawn(serial_dtrack(hub.clone(), src, port, baud, opts)),
            ),
        };
        running.local_addrs.push(addr);
        running.tasks.push(task);
    }
    let period = (config.lost_after() / 4).max(Duration::from_millis(1));
    let watchdog_hub = hub.clone();
    running.tasks.push(tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tick.tick().await;
            watchdog_hub.check_stale(watchdog_hub.now());
        }
    }));
    Ok(running)
}

/// Why a stream ended.
#[derive(Debug, PartialEq, Eq)]
pub enum StreamEnd {
    /// The peer closed it.
    Closed,
    /// No complete frame within the read timeout (idle or slow-loris).
    TimedOut,
    /// A read error.
    Error(std::io::ErrorKind),
}

/// One read with a deadline: the byte count, or how the stream ended (timed out,
/// closed by the peer, or a read error).
async fn read_within<R: AsyncRead + Unpin>(
    reader: &mut R,
    buf: &mut [u8],
    left: Duration,
) -> std::result::Result<usize, StreamEnd> {
    match tokio::time::timeout(left, reader.read(buf)).await {
        Err(_) => Err(StreamEnd::TimedOut),
        Ok(Ok(0)) => Err(StreamEnd::Closed),
        Ok(Ok(n)) => Ok(n),
        Ok(Err(e)) => Err(StreamEnd::Error(e.kind())),
    }
}

/// Reads DTrack2 frames from a byte stream into the hub until it ends.
pub async fn pump_dtrack<R: AsyncRead + Unpin>(
    hub: &Hub,
    src: SourceId,
    reader: R,
    opts: &TransportOptions,
) -> StreamEnd {
    hub.connection_opened(src);
    let end = pump_dtrack_open(hub, src, reader, opts).await;
    hub.connection_closed(src, hub.now());
    end
}

/// [`pump_dtrack`] on a connection the caller has opened and will close.
async fn pump_dtrack_open<R: AsyncRead + Unpin>(
    hub: &Hub,
    src: SourceId,
    reader: R,
    opts: &TransportOptions,
) -> StreamEnd {
    let decoder = DTrackDecoder::new(opts.limits).keep_raw(hub.is_recording());
    pump_dtrack_with(hub, src, reader, opts, decoder).await
}

/// [`pump_dtrack_open`] going on with a decoder that has already read part of the
/// stream (an identified peer's).
async fn pump_dtrack_with<R: AsyncRead + Unpin>(
    hub: &Hub,
    src: SourceId,
    mut reader: R,
    opts: &TransportOptions,
    mut decoder: DTrackDecoder,
) -> StreamEnd {
    let mut buf = vec![0u8; READ_BUF];
    let mut last_frame = Instant::now();
    let end = loop {
        let left = opts.read_timeout.saturating_sub(last_frame.elapsed());
        let n = match read_within(&mut reader, &mut buf, left).await {
            Ok(n) => n,
            Err(end) => break end,
        };
        let now = hub.now();
        let mut got = false;
        decoder.push(&buf[..n], &mut |d| {
            got |= deliver(hub, src, d, now);
        });
        if got {
            last_frame = Instant::now();
        }
    };
    if decoder.reset() {
        tracing::debug!("stream ended mid-frame; partial frame dropped");
    }
    end
}

fn deliver(hub: &Hub, src: SourceId, d: Decoded, now: Duration) -> bool {
    match d {
        Decoded::Frame(mut f, raw) => {
            f.receive_time = now;
            if let Some(raw) = raw {
                hub.record(RecordKind::DTrack, now, &raw);
            }
            hub.apply_frame(src, &f);
            true
        }
        Decoded::Dropped(e) => {
            tracing::debug!("dropped frame: {e}");
            hub.bad_frame(src);
            false
        }
    }
}

async fn tcp_listen(
    hub: Hub,
    src: SourceId,
    listener: TcpListener,
    opts: TransportOptions,
    admission: AllowList,
) {
    let slots = Arc::new(Semaphore::new(opts.max_connections));
    let candidates = Arc::new(Semaphore::new(MAX_CANDIDATES));
    loop {
        let Ok((stream, peer)) = listener.accept().await else {
            tokio::time::sleep(opts.backoff_min).await;
            continue;
        };
        if !admission.policy.allows(peer.ip()) {
            refuse(&hub, src, peer, "not on the allow-list");
            continue;
        }
        if slots.available_permits() == 0 {
            refuse(&hub, src, peer, "the source already has its connection");
            continue;
        }
        let Ok(candidate) = candidates.clone().try_acquire_owned() else {
            refuse(&hub, src, peer, "too many peers being identified");
            continue;
        };
        let _ = stream.set_nodelay(true);
        let (hub, slots, admission) = (hub.clone(), slots.clone(), admission.clone());
        // Every peer is identified on its own task, so one that sends nothing cannot
        // hold up the tracker behind it.
        tokio::spawn(async move {
            let mut stream = stream;
            let connected = Instant::now();
            let identified = identify(&hub, &mut stream, &opts, &admission).await;
            drop(candidate);
            let found = match identified {
                Ok(found) => found,
                Err(why) => return refuse(&hub, src, peer, &why),
            };
            // A plausible peer waits out the rest of its identify window for the slot:
            // a peer that is just leaving (a stray that sent a frame and closed) must
            // not cost the tracker behind it its session. The slot's queue is first
            // come, first served; a peer still waiting when the window ends is refused
            // (the tracker holds the slot for the session).
            let window = admission.identify.saturating_sub(connected.elapsed());
            let permit = match tokio::time::timeout(window, slots.acquire_owned()).await {
                Ok(Ok(permit)) => permit,
                _ => return refuse(&hub, src, peer, "the source already has its connection"),
            };
            tracing::info!("tracker connection from {peer}: identified");
            hub.connection_opened(src);
            // The frames read while it was identified, in order, at their arrival.
            for (d, now) in found.frames {
                deliver(&hub, src, d, now);
            }
            let end = pump_dtrack_with(&hub, src, &mut stream, &opts, found.decoder).await;
            tracing::info!("tracker connection from {peer} ended: {end:?}");
            // The slot is free before the peer sees the close or the source reads as
            // closed, so a tracker that reconnects on either is never refused.
            drop(permit);
            drop(stream);
            hub.connection_closed(src, hub.now());
        });
    }
}

/// Reads a new peer until it is plausible (see the module docs) or `identify` passes:
/// the hello line first when a secret is set, then frames.
async fn identify<R: AsyncRead + Unpin>(
    hub: &Hub,
    reader: &mut R,
    opts: &TransportOptions,
    adm: &Admission,
) -> std::result::Result<Candidate, String> {
    let deadline = Instant::now() + adm.identify;
    let left = || deadline.saturating_duration_since(Instant::now());
    let late = |what: &str| format!("{what} within {} ms", adm.identify.as_millis());
    let mut buf = vec![0u8; READ_BUF];
    let mut rest = Vec::new();
    if let Some(secret) = &adm.secret {
        let mut line = Vec::new();
        let newline = loop {
            if let Some(nl) = memchr::memchr(b'\n', &line) {
                break nl;
            }
            if line.len() > MAX_HELLO {
                return Err("hello line too long".into());
            }
            match read_within(reader, &mut buf, left()).await {
                Ok(n) => line.extend_from_slice(&buf[..n]),
                Err(StreamEnd::TimedOut) => return Err(late("no hello")),
                Err(end) => return Err(format!("no hello: {end:?}")),
            }
        };
        rest = line.split_off(newline + 1);
        check_hello(&line, secret).map_err(|e| e.to_string())?;
    }
    let mut found = Candidate::new(hub, opts);
    let mut chunk = rest;
    loop {
        found.push(&chunk, hub.now(), adm);
        if plausible(&found.good, adm) {
            return Ok(found);
        }
        if found.frames.len() > MAX_IDENTIFY_FRAMES {
            return Err(format!("{} frames, none plausible", found.frames.len()));
        }
        match read_within(reader, &mut buf, left()).await {
            Ok(n) => chunk = buf[..n].to_vec(),
            Err(StreamEnd::TimedOut) => {
                return Err(late(&format!(
                    "nothing plausible ({} frames, {} with the expected devices)",
                    found.frames.len(),
                    found.good.len()
                )));
            }
            Err(end) => return Err(format!("closed before it was plausible: {end:?}")),
        }
    }
}

/// Whether a frame carries `id` (a wand as a Flystick, a body as a standard body).
fn carries(f: &crate::Frame, id: DeviceId) -> bool {
    match id {
        DeviceId::Wand(n) => f.wand(n).is_some(),
        DeviceId::Body(n) => f.body(n).is_some(),
    }
}

/// Whether the last frames with the expected devices make a plausible tracker: enough
/// of them and, with a rate, the median `ts` step (or, without `ts`, the arrival
/// spacing) fitting it.
fn plausible(good: &[(Option<f64>, Instant)], adm: &Admission) -> bool {
    if good.len() < adm.frames {
        return false;
    }
    if adm.rate_hz <= 0.0 {
        return true;
    }
    let last = &good[good.len() - adm.frames..];
    let period = 1.0 / adm.rate_hz;
    let mut steps: Vec<f64> = last
        .windows(2)
        .filter_map(|w| Some(w[1].0? - w[0].0?))
        .collect();
    if steps.len() + 1 == last.len() {
        steps.sort_by(f64::total_cmp);
        let median = sculpt_core::percentile::median(&steps).unwrap_or(0.0);
        (0.5 * period..=2.0 * period).contains(&median)
    } else {
        // No tracker times: the frames came no slower than half the rate.
        let spread = last[last.len() - 1].1 - last[0].1;
        spread.as_secs_f64() <= 2.0 * period * (last.len() - 1) as f64
    }
}

/// Logs and counts a refused peer (its stream, if any, is dropped by the caller):
/// at `warn` for the first few, then at `debug` so a flood cannot fill the log.
fn refuse(hub: &Hub, src: SourceId, peer: SocketAddr, why: &str) {
    let n = hub.refused(src);
    if n <= REFUSALS_LOGGED {
        tracing::warn!(refused = n, "refusing tracking peer {peer}: {why}");
    } else {
        tracing::debug!(refused = n, "refusing tracking peer {peer}: {why}");
    }
}

/// Refusals per source logged at `warn`; later ones go to `debug`.
const REFUSALS_LOGGED: u64 = 20;

async fn tcp_connect(hub: Hub, src: SourceId, addr: SocketAddr, opts: TransportOptions) {
    let mut backoff = opts.backoff_min;
    loop {
        match tokio::time::timeout(opts.read_timeout, TcpStream::connect(addr)).await {
            Ok(Ok(stream)) => {
                let _ = stream.set_nodelay(true);
                backoff = opts.backoff_min;
                let end = pump_dtrack(&hub, src, stream, &opts).await;
                tracing::info!("tracking server {addr}: {end:?}; reconnecting");
            }
            Ok(Err(e)) => tracing::debug!("connect {addr}: {e}"),
            Err(_) => tracing::debug!("connect {addr}: timed out"),
        }
        tokio::time::sleep(backoff).await;
        backoff = (backoff * 2).min(opts.backoff_max);
    }
}

/// A peer being identified (a TCP connection or a UDP sender): its own decoder, the
/// frames it sent so far (each with its arrival on the hub clock) and the tracker times
/// and arrivals of those carrying every expected device (see the module docs).
struct Candidate {
    decoder: DTrackDecoder,
    frames: Vec<(Decoded, Duration)>,
    good: Vec<(Option<f64>, Instant)>,
    since: Instant,
}

impl Candidate {
    fn new(hub: &Hub, opts: &TransportOptions) -> Self {
        Self {
            decoder: DTrackDecoder::new(opts.limits).keep_raw(hub.is_recording()),
            frames: Vec::new(),
            good: Vec::new(),
            since: Instant::now(),
        }
    }

    /// Decodes bytes of a stream into the candidate's buffer.
    fn push(&mut self, bytes: &[u8], now: Duration, adm: &Admission) {
        self.push_with(bytes, now, adm, false);
    }

    /// Decodes one datagram (its last line may lack a line end).
    fn push_datagram(&mut self, datagram: &[u8], now: Duration, adm: &Admission) {
        self.push_with(datagram, now, adm, true);
    }

    fn push_with(&mut self, bytes: &[u8], now: Duration, adm: &Admission, datagram: bool) {
        let arrived = Instant::now();
        let (frames, good) = (&mut self.frames, &mut self.good);
        let mut sink = |d: Decoded| {
            if let Decoded::Frame(f, _) = &d
                && adm.devices.iter().all(|&id| carries(f, id))
            {
                good.push((f.tracker_time, arrived));
            }
            frames.push((d, now));
        };
        self.decoder.push(bytes, &mut sink);
        if datagram {
            self.decoder.end_datagram(&mut sink);
        }
    }
}

/// A UDP source: datagrams from one identified peer at a time. A new peer is a
/// candidate until its datagrams are plausible (the `[expect]` devices at the rate,
/// within `identify_ms`, as for TCP); the first plausible one becomes the source's
/// peer, its buffered frames are applied in order, and the others are refused until it
/// goes quiet for the read timeout. So a squatter sending garbage (or nothing the
/// config expects) never holds the port, however early or often it sends.
async fn udp(hub: Hub, src: SourceId, sock: UdpSocket, opts: TransportOptions, adm: AllowList) {
    let mut buf = vec![0u8; READ_BUF];
    // The identified peer and its decoder, until it goes quiet.
    let mut active: Option<(SocketAddr, DTrackDecoder)> = None;
    let mut candidates: HashMap<SocketAddr, Candidate> = HashMap::new();
    let mut last_datagram = Instant::now();
    loop {
        let left = opts.read_timeout.saturating_sub(last_datagram.elapsed());
        let (n, peer) = match tokio::time::timeout(left, sock.recv_from(&mut buf)).await {
            Err(_) => {
                if active.take().is_some() {
                    hub.set_connected(src, false, hub.now());
                }
                candidates.clear();
                last_datagram = Instant::now();
                continue;
            }
            Ok(Err(e)) => {
                tracing::debug!("udp receive: {e}");
                tokio::time::sleep(opts.backoff_min).await;
                continue;
            }
            Ok(Ok(got)) => got,
        };
        if !adm.policy.allows(peer.ip()) {
            refuse(&hub, src, peer, "not on the allow-list");
            continue;
        }
        let now = hub.now();
        match &mut active {
            Some((a, decoder)) if *a == peer => {
                last_datagram = Instant::now();
                let mut sink = |d| {
                    deliver(&hub, src, d, now);
                };
                decoder.push(&buf[..n], &mut sink);
                decoder.end_datagram(&mut sink);
                continue;
            }
            Some(_) => {
                refuse(&hub, src, peer, "the source already has its peer");
                continue;
            }
            None => {}
        }
        // Candidates whose identify window passed are refused and start over.
        candidates.retain(|&p, c| {
            let open = c.since.elapsed() <= adm.identify;
            if !open {
                refuse(&hub, src, p, "nothing plausible within the identify window");
            }
            open
        });
        if !candidates.contains_key(&peer) && candidates.len() >= MAX_CANDIDATES {
            refuse(&hub, src, peer, "too many peers being identified");
            continue;
        }
        let candidate = candidates
            .entry(peer)
            .or_insert_with(|| Candidate::new(&hub, &opts));
        candidate.push_datagram(&buf[..n], now, &adm);
        if plausible(&candidate.good, &adm) {
            let Some(found) = candidates.remove(&peer) else {
                continue;
            };
            for (p, _) in candidates.drain() {
                refuse(&hub, src, p, "another peer identified as the tracker");
            }
            tracing::info!("tracker datagrams from {peer}: identified");
            hub.set_connected(src, true, now);
            for (d, at) in found.frames {
                deliver(&hub, src, d, at);
            }
            active = Some((peer, found.decoder));
            last_datagram = Instant::now();
        } else if candidate.frames.len() > MAX_IDENTIFY_FRAMES {
            candidates.remove(&peer);
            refuse(&hub, src, peer, "too many frames, none plausible");
        }
    }
}

async fn serial(
    hub: Hub,
    src: SourceId,
    port: String,
    baud: u32,
    wand_id: u32,
    button_count: u8,
    opts: TransportOptions,
) {
    keep_serial_open(&port, baud, &opts, |stream| {
        pump_serial(&hub, src, stream, wand_id, button_count, &opts)
    })
    .await
}

/// DTrack2 frames from a serial port, pumped like a TCP stream.
async fn serial_dtrack(hub: Hub, src: SourceId, port: String, baud: u32, opts: TransportOptions) {
    keep_serial_open(&port, baud, &opts, |stream| {
        pump_dtrack(&hub, src, stream, &opts)
    })
    .await
}

/// Opens `port` and runs `pump` on it; after an open error, a read error or a quiet
/// spell of the read timeout, re-opens it with exponential backoff, forever.
async fn keep_serial_open<F, Fut>(port: &str, baud: u32, opts: &TransportOptions, mut pump: F)
where
    F: FnMut(tokio_serial::SerialStream) -> Fut,
    Fut: std::future::Future<Output = StreamEnd>,
{
    use tokio_serial::SerialPortBuilderExt;
    let mut backoff = opts.backoff_min;
    loop {
        match tokio_serial::new(port, baud).open_native_async() {
            Ok(stream) => {
                backoff = opts.backoff_min;
                tracing::info!("serial {port}: opened");
                let end = pump(stream).await;
                tracing::info!("serial {port}: {end:?}; reopening");
            }
            Err(e) => tracing::debug!("open serial {port}: {}", sculpt_core::error::Chain(&e)),
        }
        tokio::time::sleep(backoff).await;
        backoff = (backoff * 2).min(opts.backoff_max);
    }
}

/// Reads serial wand records from a byte stream into the hub until it ends or goes
/// quiet for the read timeout.
pub async fn pump_serial<R: AsyncRead + Unpin>(
    hub: &Hub,
    src: SourceId,
    mut reader: R,
    wand_id: u32,
    button_count: u8,
    opts: &TransportOptions,
) -> StreamEnd {
    let recording = hub.is_recording();
    let mut decoder = SerialDecoder::default();
    let mut buf = vec![0u8; 4096];
    let mut raw = Vec::new();
    let mut last = Instant::now();
    hub.connection_opened(src);
    let end = loop {
        let left = opts.read_timeout.saturating_sub(last.elapsed());
        let n = match read_within(&mut reader, &mut buf, left).await {
            Ok(n) => n,
            Err(end) => break end,
        };
        let now = hub.now();
        decoder.push(&buf[..n], &mut |r, line| match r {
            Ok(rec) => {
                last = Instant::now();
                if recording {
                    raw.clear();
                    raw.extend_from_slice(line);
                    raw.extend_from_slice(b"\r\n");
                    hub.record(RecordKind::Serial, now, &raw);
                }
                let mut f = rec.to_frame(wand_id, button_count);
                f.receive_time = now;
                hub.apply(src, &f, rec.pose.is_some());
            }
            Err(e) => {
                tracing::debug!("serial: {e}");
                hub.bad_frame(src);
            }
        });
    };
    hub.connection_closed(src, hub.now());
    end
}

/// Sleeps until `t / speed` after `start` (no sleep for a non-positive, infinite or
/// absurdly small speed whose deadline would overflow).
async fn pace(start: tokio::time::Instant, t: Duration, speed: f64) {
    if !(speed.is_finite() && speed > 0.0) {
        return;
    }
    let at = Duration::try_from_secs_f64(t.as_secs_f64() / speed)
        .ok()
        .and_then(|d| start.checked_add(d));
    if let Some(at) = at {
        tokio::time::sleep_until(at).await;
    }
}

/// Writes `(time, bytes)` items to a stream, each at its time divided by `speed` after
/// the start (`speed <= 0` or infinite: as fast as possible). Returns bytes written.
pub async fn send_paced<W: AsyncWrite + Unpin>(
    w: &mut W,
    items: impl IntoIterator<Item = (Duration, Vec<u8>)>,
    speed: f64,
) -> std::io::Result<u64> {
    let start = tokio::time::Instant::now();
    let mut total = 0;
    for (t, bytes) in items {
        pace(start, t, speed).await;
        w.write_all(&bytes).await?;
        total += bytes.len() as u64;
    }
    w.flush().await?;
    Ok(total)
}

/// Sends `(time, datagram)` items to `target`, paced like [`send_paced`].
pub async fn send_paced_udp(
    sock: &UdpSocket,
    target: SocketAddr,
    items: impl IntoIterator<Item = (Duration, Vec<u8>)>,
    speed: f64,
) -> std::io::Result<u64> {
    let start = tokio::time::Instant::now();
    let mut total = 0;
    for (t, bytes) in items {
        pace(start, t, speed).await;
        sock.send_to(&bytes, target).await?;
        total += bytes.len() as u64;
    }
    Ok(total)
}

/// Simulator (or decoded) frames as paced items: DTrack2 bytes at each frame's
/// receive time.
pub fn frames_as_items(
    frames: impl IntoIterator<Item = crate::Frame>,
) -> impl Iterator<Item = (Duration, Vec<u8>)> {
    frames.into_iter().map(|f| {
        let mut bytes = Vec::with_capacity(512);
        crate::dtrack::encode_frame(&f, &mut bytes);
        (f.receive_time, bytes)
    })
}
