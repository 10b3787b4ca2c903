//! Tracking-server emulation: a recorded session's raw bytes, sent with their original
//! timing to a running display server.
//!
//! - [`Endpoint::Listen`] (`--serve tcp://127.0.0.1:PORT`): act as the tracking server
//!   that the display server connects to. Port 0 picks a free port; the bound address is
//!   reported through [`ServeOptions::on_listening`] (the binary prints it).
//! - [`Endpoint::Connect`] (`--connect tcp://HOST:PORT`): connect out to a display
//!   server that listens, retrying with backoff until [`ServeOptions::connect_timeout`].
//! - [`Endpoint::Serial`] (`--serve serial:///dev/pts/N`): write to a serial device or
//!   a pseudo-terminal.
//!
//! Like a real tracking server the stream does not pause for its client: when the
//! connection drops (the display server crashed or restarted), records due meanwhile
//! are counted as missed, and sending resumes with the next due record once a client is
//! back. Timing is measured from the start of sending; [`ServeOptions::speed`] scales
//! it (0 sends as fast as possible).
//!
//! **Delivery.** DTrack2 has no acknowledgement, so "written to the socket" is not
//! "taken by the receiver". Over TCP the sender learns what the connection can tell it
//! ([`Delivery`]): when everything is written it closes its sending side and waits for
//! the receiver to close in turn. A receiver that read the stream to its end closes
//! cleanly ([`Delivery::ReadToEnd`]); one that refused the connection (its slot was
//! taken) or went away with data unread (it exited) resets it
//! ([`Delivery::NotTaken`]). Whether the receiver then *applied* the frames is beyond
//! what DTrack2 can say. A serial line cannot tell at all ([`Delivery::Unknown`]).
//!
//! **Exact counts.** Every record lands in exactly one count of the [`ServeReport`]:
//! written on a connection that ended well or could not tell (`sent - unconfirmed`),
//! written on a connection the receiver closed or reset before the end
//! ([`ServeReport::unconfirmed`]: a refused connection, a receiver that crashed; some
//! may have been read, none is known to have been), or due while no receiver was
//! connected ([`ServeReport::missed`]). When listening, a further client that connects
//! while the session goes to the first is closed at once and counted
//! ([`ServeReport::other_clients`]): it got none of the session, and if it was the
//! display server, a client that connected first (a stray `nc`) took its frames.
//! [`ServeReport::lost_data`] says whether any of that happened; `replay` then exits 3.
//! Before each write the sender checks, without blocking, that the receiver has not
//! closed or reset the connection, so a record is never written to a receiver known
//! to be gone.
//!
//! ```
//! use std::io::Read;
//! use std::time::Duration;
//! use replay::serve::{serve, Endpoint, ServeOptions};
//! let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
//! let addr = listener.local_addr().unwrap();
//! let reader = std::thread::spawn(move || {
//!     let (mut s, _) = listener.accept().unwrap();
//!     let mut got = String::new();
//!     s.read_to_string(&mut got).unwrap();
//!     got
//! });
//! let records = vec![(Duration::ZERO, b"fr 1\r\n".to_vec()), (Duration::from_millis(5), b"fr 2\r\n".to_vec())];
//! let report = serve(&records, &Endpoint::Connect(addr), ServeOptions::default()).unwrap();
//! assert_eq!(report.sent, 2);
//! assert_eq!(reader.join().unwrap(), "fr 1\r\nfr 2\r\n");
//! ```

use std::io::Write;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::error::{EndpointError, Error, Result};

/// Where the records go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// Listen here and send to whoever connects (the display server).
    Listen(SocketAddr),
    /// Connect to a display server listening here.
    Connect(SocketAddr),
    /// Write to this serial device or pseudo-terminal.
    Serial(PathBuf),
}

impl Endpoint {
    /// Parses `tcp://HOST:PORT` (with `listen` choosing [`Endpoint::Listen`] or
    /// [`Endpoint::Connect`]) or `serial:///path/to/device`. A bare `PORT` means
    /// `127.0.0.1:PORT`.
    pub fn parse(text: &str, listen: bool) -> Result<Self> {
        let bad = |why: &'static str| {
            Error::Endpoint(EndpointError::Malformed {
                text: text.to_string(),
                why,
            })
        };
        if let Some(path) = text.strip_prefix("serial://") {
            if path.is_empty() {
                return Err(bad("no device path"));
            }
            return Ok(Endpoint::Serial(PathBuf::from(path)));
        }
        let hostport = text.strip_prefix("tcp://").unwrap_or(text);
        let addr: SocketAddr = match hostport.parse::<u16>() {
            Ok(port) => SocketAddr::from(([127, 0, 0, 1], port)),
            Err(_) => hostport
                .parse()
                .map_err(|_| bad("expected tcp://IP:PORT, PORT or serial:///DEVICE"))?,
        };
        Ok(if listen {
            Endpoint::Listen(addr)
        } else {
            Endpoint::Connect(addr)
        })
    }
}

/// How to send.
pub struct ServeOptions<'a> {
    /// Time scale: 1 is the original timing, 2 twice as fast, 0 as fast as possible.
    pub speed: f64,
    /// How long to wait for the first client, or to reach the server (seconds).
    pub connect_timeout: Duration,
    /// Stop when no client is back this long after a disconnect.
    pub reconnect_timeout: Duration,
    /// Called once with the bound address when listening.
    pub on_listening: Option<&'a mut dyn FnMut(SocketAddr)>,
    /// Called after each record with (records done, total).
    pub on_progress: Option<&'a mut dyn FnMut(usize, usize)>,
    /// Written first on every TCP connection: the display server's hello line
    /// (`tracking::config::hello_line`) when its source has a `secret`.
    pub hello: Option<Vec<u8>>,
}

impl Default for ServeOptions<'_> {
    fn default() -> Self {
        Self {
            speed: 1.0,
            connect_timeout: Duration::from_secs(30),
            reconnect_timeout: Duration::from_secs(30),
            on_listening: None,
            on_progress: None,
            hello: None,
        }
    }
}

/// What a serve run did (see "Exact counts" in the module docs).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct ServeReport {
    /// Records written to a client.
    pub sent: usize,
    /// Bytes written.
    pub bytes: u64,
    /// Records that fell due while no client was connected.
    pub missed: usize,
    /// Of `sent`, the records written on a connection that the receiver then closed or
    /// reset before the end (refused, crashed): not known to have been read.
    pub unconfirmed: usize,
    /// Listening: clients that connected while the session went to another one, and
    /// were closed with none of it (the first few addresses in `other_peers`).
    pub other_clients: usize,
    /// The first [`OTHER_PEERS_KEPT`] of those clients' addresses.
    pub other_peers: Vec<SocketAddr>,
    /// Connections made (1 without reconnects).
    pub connections: usize,
    /// What the last connection says about the receiver taking the data.
    pub delivery: Delivery,
}

/// What a sender can know about its receiver taking the data (see the module docs).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Delivery {
    /// The receiver read the stream to its end and closed the connection (over TCP).
    ReadToEnd,
    /// The receiver did not take the data; the reason says how we know.
    NotTaken(NotTaken),
    /// The link cannot tell (a serial line), or the receiver neither closed nor reset
    /// the connection within [`ACK_WAIT`].
    #[default]
    Unknown,
}

/// How a sender knows its receiver did not take the data.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NotTaken {
    /// It closed the connection before the end.
    ClosedEarly,
    /// The connection failed; the system's message.
    Failed(String),
    /// It reset the connection; the system's message.
    Reset(String),
    /// Records fell due while it was disconnected.
    Missed(usize),
    /// It went away and did not come back within this time.
    GoneAway(Duration),
}

/// How many addresses of turned-away clients a report keeps.
pub const OTHER_PEERS_KEPT: usize = 8;

impl ServeReport {
    /// Records not known to have reached a receiver: missed, or written on a
    /// connection that broke.
    pub fn lost(&self) -> usize {
        self.missed + self.unconfirmed
    }

    /// Whether the run lost data: records lost, a receiver known not to have taken the
    /// stream, or another client turned away while the session went to the first.
    pub fn lost_data(&self) -> bool {
        self.lost() > 0 || self.other_clients > 0 || self.delivery.failed()
    }

    /// One line for the summary: what was lost, or that nothing was.
    pub fn losses(&self) -> String {
        let mut parts = Vec::new();
        if self.missed > 0 {
            parts.push(format!(
                "{} records fell due while no receiver was connected",
                self.missed
            ));
        }
        if self.unconfirmed > 0 {
            parts.push(format!(
                "{} records went to connections the receiver closed or reset before the end",
                self.unconfirmed
            ));
        }
        if self.other_clients > 0 {
            let peers: Vec<String> = self.other_peers.iter().map(|p| p.to_string()).collect();
            parts.push(format!(
                "{} other client connection(s) ({}) got none of the session: a client that \
                 connected first took it",
                self.other_clients,
                peers.join(", ")
            ));
        }
        if parts.is_empty() {
            "nothing lost".into()
        } else {
            format!("DATA LOST: {}", parts.join("; "))
        }
    }
}

impl std::fmt::Display for NotTaken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotTaken::ClosedEarly => f.write_str("it closed the connection before the end"),
            NotTaken::Failed(e) => write!(f, "the connection failed: {e}"),
            NotTaken::Reset(e) => write!(f, "it reset the connection ({e})"),
            NotTaken::Missed(n) => write!(f, "{n} records fell due while it was disconnected"),
            NotTaken::GoneAway(t) => {
                write!(f, "it went away and did not come back within {t:?}")
            }
        }
    }
}

impl Delivery {
    /// Whether the data is known not to have been taken.
    pub fn failed(&self) -> bool {
        matches!(self, Delivery::NotTaken(_))
    }
}

impl std::fmt::Display for Delivery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Delivery::ReadToEnd => f.write_str(
                "the receiver read the stream to its end (DTrack2 has no acknowledgement, \
                 so whether it applied the frames is not known here)",
            ),
            Delivery::NotTaken(why) => write!(f, "the receiver did not take the data: {why}"),
            Delivery::Unknown => f.write_str(
                "receiver acknowledgement not available (DTrack2 has none, and the link \
                 did not say)",
            ),
        }
    }
}

/// How long the sender waits, after its last record, for the receiver to close.
pub const ACK_WAIT: Duration = Duration::from_secs(10);

/// Ends a TCP stream after the last record: half-closes it, then waits up to `wait`
/// for the receiver to close in turn (see [`Delivery`]).
fn finish_tcp(stream: &mut TcpStream, wait: Duration) -> Delivery {
    use std::io::{ErrorKind, Read};
    let not_taken = Delivery::NotTaken;
    // A receiver that closed while we were still sending did not read to the end: the
    // display server never closes a healthy stream on its own.
    if stream.set_nonblocking(true).is_ok() {
        let mut probe = [0u8; 1];
        let early = stream.peek(&mut probe);
        let _ = stream.set_nonblocking(false);
        match early {
            Ok(0) => return not_taken(NotTaken::ClosedEarly),
            Err(e) if e.kind() != ErrorKind::WouldBlock => {
                return not_taken(NotTaken::Failed(e.to_string()));
            }
            _ => {}
        }
    }
    if let Err(e) = stream.shutdown(std::net::Shutdown::Write) {
        return not_taken(NotTaken::Failed(e.to_string()));
    }
    let _ = stream.set_read_timeout(Some(wait));
    let mut buf = [0u8; 4096];
    loop {
        match stream.read(&mut buf) {
            Ok(0) => return Delivery::ReadToEnd,
            Ok(_) => {} // the receiver has nothing to say; ignore it
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Delivery::Unknown;
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return not_taken(NotTaken::Reset(e.to_string())),
        }
    }
}

/// The open sink: a client socket or a device.
enum Sink {
    Tcp(TcpStream),
    File(std::fs::File),
}

impl Sink {
    /// Whether the receiver has closed or reset the connection (checked without
    /// blocking; a serial device cannot tell).
    fn gone(&mut self) -> bool {
        let Sink::Tcp(s) = self else { return false };
        if s.set_nonblocking(true).is_err() {
            return true;
        }
        let mut probe = [0u8; 64];
        let gone = loop {
            match s.peek(&mut probe) {
                Ok(0) => break true,
                // The receiver has nothing to say; anything it sends is ignored.
                Ok(_) => {
                    use std::io::Read;
                    if s.read(&mut probe).is_err() {
                        break true;
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break false,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(_) => break true,
            }
        };
        gone || s.set_nonblocking(false).is_err()
    }

    fn write_all(&mut self, b: &[u8]) -> std::io::Result<()> {
        match self {
            Sink::Tcp(s) => s.write_all(b),
            Sink::File(f) => f.write_all(b).and_then(|()| f.flush()),
        }
    }
}

/// Opens (or re-opens) the sink for an endpoint.
struct Opener {
    endpoint: Endpoint,
    listener: Option<TcpListener>,
    /// Written first on every TCP connection.
    hello: Option<Vec<u8>>,
}

impl Opener {
    fn new(endpoint: &Endpoint, on_listening: Option<&mut dyn FnMut(SocketAddr)>) -> Result<Self> {
        let listener = match endpoint {
            Endpoint::Listen(addr) => {
                let l = TcpListener::bind(addr).map_err(|source| Error::Socket {
                    what: "cannot listen on",
                    addr: *addr,
                    source,
                })?;
                let setting_up = |source| Error::Socket {
                    what: "setting up",
                    addr: *addr,
                    source,
                };
                l.set_nonblocking(true).map_err(setting_up)?;
                let bound = l.local_addr().map_err(setting_up)?;
                if let Some(cb) = on_listening {
                    cb(bound);
                }
                Some(l)
            }
            _ => None,
        };
        Ok(Self {
            endpoint: endpoint.clone(),
            listener,
            hello: None,
        })
    }

    /// Listening: accepts and closes every client waiting now (the session goes to
    /// the one it has), counting them in `report`.
    fn turn_away(&self, report: &mut ServeReport) {
        let Some(l) = &self.listener else { return };
        while let Ok((s, peer)) = l.accept() {
            drop(s);
            report.other_clients += 1;
            if report.other_peers.len() < OTHER_PEERS_KEPT {
                report.other_peers.push(peer);
            }
        }
    }

    /// Tries to get a sink until `deadline`; `None` when it passes.
    fn open(&self, deadline: Instant) -> Option<Sink> {
        let mut backoff = Duration::from_millis(10);
        loop {
            let got = match (&self.endpoint, &self.listener) {
                (Endpoint::Listen(_), Some(l)) => l.accept().ok().and_then(|(s, _)| {
                    s.set_nonblocking(false).ok()?;
                    s.set_nodelay(true).ok()?;
                    Some(Sink::Tcp(s))
                }),
                (Endpoint::Connect(addr), _) => {
                    TcpStream::connect_timeout(addr, Duration::from_millis(500))
                        .ok()
                        .and_then(|s| {
                            s.set_nodelay(true).ok()?;
                            Some(Sink::Tcp(s))
                        })
                }
                (Endpoint::Serial(path), _) => std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .ok()
                    .map(Sink::File),
                (Endpoint::Listen(_), None) => None,
            };
            let got = match (got, &self.hello) {
                (Some(Sink::Tcp(mut s)), Some(hello)) => std::io::Write::write_all(&mut s, hello)
                    .ok()
                    .map(|()| Sink::Tcp(s)),
                (got, _) => got,
            };
            if got.is_some() {
                return got;
            }
            let now = Instant::now();
            if now >= deadline {
                return None;
            }
            std::thread::sleep(backoff.min(deadline - now));
            backoff = (backoff * 2).min(Duration::from_millis(200));
        }
    }
}

/// Sends `records` (receive time since the start, raw bytes) to `endpoint` with their
/// original timing scaled by [`ServeOptions::speed`]. Fails when no client comes within
/// the connect timeout; a client lost for longer than the reconnect timeout ends the
/// run early (the rest is reported in [`ServeReport::missed`]).
pub fn serve(
    records: &[(Duration, Vec<u8>)],
    endpoint: &Endpoint,
    mut options: ServeOptions<'_>,
) -> Result<ServeReport> {
    if !(options.speed.is_finite() && options.speed >= 0.0) {
        return Err(Error::Endpoint(EndpointError::Speed {
            speed: options.speed,
        }));
    }
    let mut opener = Opener::new(endpoint, options.on_listening.take())?;
    opener.hello = options.hello.take();
    let mut report = ServeReport::default();
    let mut sink = opener.open(Instant::now() + options.connect_timeout);
    if sink.is_none() {
        return Err(Error::Endpoint(EndpointError::NoConnection {
            endpoint: format!("{endpoint:?}"),
            timeout: options.connect_timeout,
        }));
    }
    report.connections = 1;
    let start = Instant::now();
    let first = records.first().map_or(Duration::ZERO, |r| r.0);
    let due = |t: Duration| -> Instant {
        if options.speed == 0.0 {
            start
        } else {
            start + (t.saturating_sub(first)).div_f64(options.speed)
        }
    };
    let mut i = 0;
    // Records written on the current connection (unconfirmed if it breaks).
    let mut on_connection = 0;
    // A broken connection: its records are not known to have been read.
    let broke = |report: &mut ServeReport, on_connection: &mut usize| {
        report.unconfirmed += std::mem::take(on_connection);
    };
    while i < records.len() {
        let (t, bytes) = &records[i];
        let when = due(*t);
        let now = Instant::now();
        if when > now {
            std::thread::sleep(when - now);
        }
        if sink.as_mut().is_some_and(Sink::gone) {
            sink = None;
            broke(&mut report, &mut on_connection);
        }
        if sink.is_some() {
            opener.turn_away(&mut report);
        }
        match sink.as_mut() {
            Some(s) => match s.write_all(bytes) {
                Ok(()) => {
                    report.sent += 1;
                    report.bytes += bytes.len() as u64;
                    on_connection += 1;
                    i += 1;
                }
                Err(_) => {
                    sink = None;
                    // The failed record goes to the next connection; those before it
                    // on this one are unconfirmed.
                    broke(&mut report, &mut on_connection);
                }
            },
            None => {
                // Wait for a client; records falling due meanwhile are missed.
                let reconnect_deadline = Instant::now() + options.reconnect_timeout;
                sink = opener.open(reconnect_deadline);
                if sink.is_none() {
                    report.missed += records.len() - i;
                    break;
                }
                report.connections += 1;
                let now = Instant::now();
                while i < records.len() && due(records[i].0) + Duration::from_millis(1) < now {
                    report.missed += 1;
                    i += 1;
                }
            }
        }
        if let Some(cb) = options.on_progress.as_mut() {
            cb(i, records.len());
        }
    }
    report.delivery = match sink.as_mut() {
        // Connecting to a display server: records that fell due while it was away never
        // reached it, however the last connection ended (a server whose slots are full
        // closes every connection at once, and may close the last one cleanly). When
        // listening, clients come and go as they choose (a display server restarted
        // after a crash), as with a real tracker; the summary counts what they missed.
        Some(Sink::Tcp(_)) if report.missed > 0 && matches!(endpoint, Endpoint::Connect(_)) => {
            Delivery::NotTaken(NotTaken::Missed(report.missed))
        }
        Some(Sink::Tcp(stream)) => finish_tcp(stream, ACK_WAIT),
        Some(Sink::File(_)) => Delivery::Unknown,
        None => Delivery::NotTaken(NotTaken::GoneAway(options.reconnect_timeout)),
    };
    if matches!(
        report.delivery,
        Delivery::NotTaken(NotTaken::ClosedEarly | NotTaken::Reset(_) | NotTaken::Failed(_))
    ) {
        broke(&mut report, &mut on_connection);
    }
    opener.turn_away(&mut report);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    fn recs(n: usize, step_ms: u64) -> Vec<(Duration, Vec<u8>)> {
        (0..n)
            .map(|i| {
                (
                    Duration::from_millis(i as u64 * step_ms),
                    format!("fr {i}\r\n\r\n").into_bytes(),
                )
            })
            .collect()
    }

    #[test]
    fn endpoints_parse() {
        assert_eq!(
            Endpoint::parse("tcp://127.0.0.1:5000", true).unwrap(),
            Endpoint::Listen("127.0.0.1:5000".parse().unwrap())
        );
        assert_eq!(
            Endpoint::parse("7000", false).unwrap(),
            Endpoint::Connect("127.0.0.1:7000".parse().unwrap())
        );
        assert_eq!(
            Endpoint::parse("serial:///dev/pts/4", true).unwrap(),
            Endpoint::Serial("/dev/pts/4".into())
        );
        assert!(Endpoint::parse("tcp://nowhere", true).is_err());
        assert!(Endpoint::parse("serial://", true).is_err());
    }

    #[test]
    fn listening_sends_everything_in_order_to_the_client() {
        let records = recs(50, 1);
        let (tx, rx) = std::sync::mpsc::channel();
        let client = std::thread::spawn(move || {
            let addr: SocketAddr = rx.recv().unwrap();
            let mut s = TcpStream::connect(addr).unwrap();
            let mut got = Vec::new();
            s.read_to_end(&mut got).unwrap();
            got
        });
        let mut on_listening = |a: SocketAddr| tx.send(a).unwrap();
        let report = serve(
            &records,
            &Endpoint::Listen("127.0.0.1:0".parse().unwrap()),
            ServeOptions {
                speed: 0.0,
                on_listening: Some(&mut on_listening),
                ..ServeOptions::default()
            },
        )
        .unwrap();
        assert_eq!(report.sent, 50);
        assert_eq!(report.missed, 0);
        let expected: Vec<u8> = records.iter().flat_map(|r| r.1.clone()).collect();
        assert_eq!(client.join().unwrap(), expected);
    }

    #[test]
    fn no_client_is_a_clear_error() {
        let e = serve(
            &recs(2, 1),
            &Endpoint::Listen("127.0.0.1:0".parse().unwrap()),
            ServeOptions {
                connect_timeout: Duration::from_millis(50),
                ..ServeOptions::default()
            },
        )
        .unwrap_err();
        assert!(
            matches!(e, Error::Endpoint(EndpointError::NoConnection { .. })),
            "{e:?}"
        );
        assert!(e.to_string().contains("no connection"), "{e}");
    }

    #[test]
    fn a_dropped_client_is_replaced_and_sending_resumes() {
        // The first client reads one record and hangs up; the second reads the rest.
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let server = std::thread::spawn(move || {
            let (s, _) = listener.accept().unwrap();
            drop(s);
            let (mut s, _) = listener.accept().unwrap();
            let mut got = Vec::new();
            s.read_to_end(&mut got).unwrap();
            got
        });
        let records = recs(400, 1);
        let report = serve(
            &records,
            &Endpoint::Connect(addr),
            ServeOptions {
                speed: 1.0,
                ..ServeOptions::default()
            },
        )
        .unwrap();
        let got = server.join().unwrap();
        assert_eq!(report.connections, 2, "{report:?}");
        assert_eq!(report.sent + report.missed, 400);
        // The second connection got whole records, ending with the last one.
        let text = String::from_utf8(got).unwrap();
        assert!(text.ends_with("fr 399\r\n\r\n"), "{text}");
        assert!(text.starts_with("fr "));
    }

    /// Regression (issue 31, item 3): records written on connections the receiver
    /// refused (accepted, then closed with the record unread) were counted as sent, and
    /// the run said nothing was missed. They are now unconfirmed, every record is
    /// counted once, and the report says the run lost data.
    #[test]
    fn records_written_to_refused_connections_are_unconfirmed() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let receiver = std::thread::spawn(move || {
            for _ in 0..3 {
                let (s, _) = listener.accept().unwrap();
                // Refuse once a record is queued, leaving it unread (a reset).
                let mut probe = [0u8; 1];
                let _ = s.peek(&mut probe);
                drop(s);
            }
            let (mut s, _) = listener.accept().unwrap();
            let mut got = Vec::new();
            s.read_to_end(&mut got).unwrap();
            got
        });
        let records = recs(300, 2);
        let report = serve(
            &records,
            &Endpoint::Connect(addr),
            ServeOptions {
                speed: 1.0,
                ..ServeOptions::default()
            },
        )
        .unwrap();
        let got = receiver.join().unwrap();
        assert_eq!(report.unconfirmed, 3, "{report:?}");
        assert_eq!(report.sent + report.missed, 300, "{report:?}");
        assert_eq!(report.connections, 4, "{report:?}");
        assert!(report.lost_data() && report.losses().starts_with("DATA LOST"));
        // The last receiver read exactly the records not counted lost.
        let frames = String::from_utf8(got).unwrap().matches("fr ").count();
        assert_eq!(frames, 300 - report.lost(), "{report:?}");
    }

    /// Regression (issue 31, item 3): a second client that connected while the session
    /// went to the first got nothing, and the run reported success. It is now closed at
    /// once and counted, and the run lost data.
    #[test]
    fn a_second_client_while_serving_is_turned_away_and_counted() {
        let (tx, rx) = std::sync::mpsc::channel();
        let clients = std::thread::spawn(move || {
            let addr: SocketAddr = rx.recv().unwrap();
            let mut first = TcpStream::connect(addr).unwrap();
            std::thread::sleep(Duration::from_millis(100));
            let mut second = TcpStream::connect(addr).unwrap();
            let mut got = Vec::new();
            let _ = second.read_to_end(&mut got);
            let mut all = Vec::new();
            first.read_to_end(&mut all).unwrap();
            (got.len(), all.len())
        });
        let mut on_listening = |a: SocketAddr| tx.send(a).unwrap();
        let report = serve(
            &recs(200, 2),
            &Endpoint::Listen("127.0.0.1:0".parse().unwrap()),
            ServeOptions {
                speed: 1.0,
                on_listening: Some(&mut on_listening),
                ..ServeOptions::default()
            },
        )
        .unwrap();
        let (second, first) = clients.join().unwrap();
        assert_eq!(second, 0);
        assert!(first > 0);
        assert_eq!(report.other_clients, 1, "{report:?}");
        assert_eq!((report.sent, report.lost()), (200, 0), "{report:?}");
        assert!(report.lost_data(), "{report:?}");
    }
}
