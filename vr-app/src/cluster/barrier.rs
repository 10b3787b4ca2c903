//! The frame barrier (frame lock and software swap lock) over core NATS.
//!
//! Each node publishes `{"node":NAME,"frame":N}` on `<session>.barrier` when frame N
//! is ready, then waits until every *live* member has reported frame N or later. A
//! member that has not within the timeout is dropped from the barrier (the others
//! present without it); any report from a dropped member re-admits it. A node that
//! was held up (stopped, slow) finds the others ahead: its waits pass at once and it
//! jumps to their frame number, so the nodes present the same frame again.

use std::collections::BTreeMap;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::{ClusterError, Percentiles, unix_ns};

/// One barrier report.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ready {
    /// The reporting node.
    pub node: String,
    /// The frame it has ready.
    pub frame: u64,
}

/// A barrier member as this node sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Member {
    /// The latest frame it reported ready.
    frame: Option<u64>,
    /// Dropped by a timeout, until it reports again.
    dropped: bool,
}

/// What the barrier did, for the node's report.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct BarrierStats {
    /// Frames passed.
    pub frames: u64,
    /// Wait per frame, from publishing ready to passing (milliseconds).
    pub wait_ms: Percentiles,
    /// Members dropped by a timeout.
    pub dropped: u64,
    /// Dropped members re-admitted by a later report.
    pub readmitted: u64,
    /// Reports that were not barrier reports (counted and ignored).
    pub garbage: u64,
    /// The first [`LOCK_LOG_CAP`] frames: when each was ready here and passed, and
    /// which members it waited for (to check the swap lock from outside).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub log: Vec<LockRecord>,
}

/// Frames a barrier keeps in [`BarrierStats::log`].
pub const LOCK_LOG_CAP: usize = 2048;

/// One frame through the barrier on one node.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockRecord {
    /// The frame.
    pub frame: u64,
    /// When this node reported it ready (Unix nanoseconds).
    pub ready_ns: u64,
    /// When it passed the barrier, to be presented (Unix nanoseconds).
    pub pass_ns: u64,
    /// The live members at the pass: each had reported this frame or a later one.
    pub waited_for: Vec<String>,
}

/// The barrier's state on one node; reports arrive on a channel fed by the
/// subscription (see [`super::node`]).
#[derive(Debug)]
pub struct Barrier {
    me: String,
    members: BTreeMap<String, Member>,
    timeout: Duration,
    rx: mpsc::Receiver<Vec<u8>>,
    waits: Vec<f64>,
    stats: BarrierStats,
    /// When the last report was made (Unix nanoseconds).
    ready_ns: u64,
}

impl Barrier {
    /// A barrier for `me` among `members` (the configured nodes), fed by `rx` (raw
    /// report payloads).
    pub fn new(
        me: &str,
        members: &[String],
        timeout: Duration,
        rx: mpsc::Receiver<Vec<u8>>,
    ) -> Self {
        Self {
            me: me.to_string(),
            members: members
                .iter()
                .filter(|m| *m != me)
                .map(|m| {
                    (
                        m.clone(),
                        Member {
                            frame: None,
                            dropped: false,
                        },
                    )
                })
                .collect(),
            timeout,
            rx,
            waits: Vec::new(),
            stats: BarrierStats::default(),
            ready_ns: 0,
        }
    }

    /// The report to publish for `frame`.
    pub fn report(&mut self, frame: u64) -> Result<Vec<u8>, ClusterError> {
        self.ready_ns = unix_ns();
        serde_json::to_vec(&Ready {
            node: self.me.clone(),
            frame,
        })
        .map_err(|cause| ClusterError::Encode {
            what: "a barrier report",
            cause,
        })
    }

    fn take(&mut self, payload: &[u8]) {
        let Ok(r) = serde_json::from_slice::<Ready>(payload) else {
            self.stats.garbage += 1;
            return;
        };
        if r.node == self.me {
            return;
        }
        let Some(m) = self.members.get_mut(&r.node) else {
            // Not a configured node: counted, never waited for.
            self.stats.garbage += 1;
            return;
        };
        if m.dropped {
            m.dropped = false;
            self.stats.readmitted += 1;
            tracing::info!(node = %r.node, frame = r.frame, "barrier: node re-admitted");
        }
        m.frame = Some(m.frame.map_or(r.frame, |f| f.max(r.frame)));
    }

    /// Waits (after this node published its report for `frame`) until every live
    /// member is at `frame` or later, dropping those that are not within the timeout.
    /// Returns the next frame number: `frame + 1`, or the live members' latest frame
    /// when they are ahead (this node was held up).
    pub fn wait(&mut self, frame: u64) -> u64 {
        let start = Instant::now();
        let deadline = start + self.timeout;
        loop {
            while let Ok(p) = self.rx.try_recv() {
                self.take(&p);
            }
            let behind: Vec<String> = self
                .members
                .iter()
                .filter(|(_, m)| !m.dropped && m.frame.is_none_or(|f| f < frame))
                .map(|(n, _)| n.clone())
                .collect();
            if behind.is_empty() {
                break;
            }
            let now = Instant::now();
            if now >= deadline {
                for n in behind {
                    tracing::warn!(node = %n, frame, "barrier: node dropped (timeout)");
                    if let Some(m) = self.members.get_mut(&n) {
                        m.dropped = true;
                    }
                    self.stats.dropped += 1;
                }
                break;
            }
            if let Ok(p) = self.rx.recv_timeout(deadline - now) {
                self.take(&p);
            }
        }
        self.waits.push(start.elapsed().as_secs_f64() * 1e3);
        self.stats.frames += 1;
        if self.stats.log.len() < LOCK_LOG_CAP {
            self.stats.log.push(LockRecord {
                frame,
                ready_ns: self.ready_ns,
                pass_ns: unix_ns(),
                waited_for: self
                    .members
                    .iter()
                    .filter(|(_, m)| !m.dropped)
                    .map(|(n, _)| n.clone())
                    .collect(),
            });
        }
        let ahead = self
            .members
            .values()
            .filter(|m| !m.dropped)
            .filter_map(|m| m.frame)
            .max()
            .unwrap_or(0);
        (frame + 1).max(ahead)
    }

    /// Members currently live (not dropped), this node included.
    pub fn live(&self) -> usize {
        1 + self.members.values().filter(|m| !m.dropped).count()
    }

    /// Whether `node` is this node or a member not dropped (a configured member that
    /// has not reported yet counts as live until its first timeout).
    pub fn is_live(&self, node: &str) -> bool {
        node == self.me || self.members.get(node).is_some_and(|m| !m.dropped)
    }

    /// The statistics so far.
    pub fn stats(&mut self) -> BarrierStats {
        let mut s = self.stats.clone();
        s.wait_ms = Percentiles::of(&mut self.waits.clone());
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(node: &str, frame: u64) -> Vec<u8> {
        serde_json::to_vec(&Ready {
            node: node.into(),
            frame,
        })
        .unwrap()
    }

    #[test]
    fn a_silent_member_is_dropped_and_a_report_readmits_it() {
        let (tx, rx) = mpsc::channel();
        let names = ["a".to_string(), "b".to_string(), "c".to_string()];
        let mut b = Barrier::new("a", &names, Duration::from_millis(30), rx);
        tx.send(report("b", 0)).unwrap();
        tx.send(report("c", 0)).unwrap();
        assert_eq!(b.wait(0), 1);
        tx.send(report("b", 1)).unwrap();
        // c is silent: dropped by the timeout, the frame passes without it.
        assert_eq!(b.wait(1), 2);
        assert_eq!((b.stats().dropped, b.live()), (1, 2));
        tx.send(report("b", 2)).unwrap();
        assert_eq!(b.wait(2), 3, "a dropped member is not waited for");
        assert_eq!(b.stats().dropped, 1);
        // c comes back, behind; it is re-admitted and waited for again.
        tx.send(report("c", 1)).unwrap();
        tx.send(b"not a report".to_vec()).unwrap();
        tx.send(report("stranger", 9)).unwrap();
        tx.send(report("b", 3)).unwrap();
        tx.send(report("c", 3)).unwrap();
        assert_eq!(b.wait(3), 4);
        let s = b.stats();
        assert_eq!((s.readmitted, s.garbage, s.frames), (1, 2, 4));
        assert_eq!(b.live(), 3);
    }

    #[test]
    fn a_node_held_up_jumps_to_the_others_frame() {
        let (tx, rx) = mpsc::channel();
        let names = ["a".to_string(), "b".to_string()];
        let mut b = Barrier::new("a", &names, Duration::from_millis(30), rx);
        tx.send(report("b", 40)).unwrap();
        assert_eq!(b.wait(5), 40);
        assert_eq!(b.stats().dropped, 0);
    }
}
