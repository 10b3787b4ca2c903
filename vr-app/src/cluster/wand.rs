//! The other sculptors' wands: each owner node publishes its wand's pose on
//! `<session>.wand.<node>` (core NATS, at most `[cluster] wand_rate` times a second,
//! only when the wand has a new tracked sample), and every node draws the wands of the
//! owners on *other* feeds (an owner on its own feed is its own interaction's cursor
//! already) as overlay lines in their own colour. A wand not heard of for
//! `[cluster] wand_stale` seconds is no longer drawn. Messages that are not wand poses
//! of a configured owner are counted and ignored.
//!
//! ```
//! use std::time::{Duration, Instant};
//! use glam::{DQuat, DVec3};
//! use vr_app::cluster::wand::{PeerWands, WandPose};
//! let t0 = Instant::now();
//! let mut peers = PeerWands::new(["desk".to_string()], [], Duration::from_secs(1));
//! let pose = WandPose::new(DVec3::new(0.0, 1.2, 0.3), DQuat::IDENTITY, false);
//! peers.take("desk", &pose.encode()?, t0);
//! assert!(!peers.lines().is_empty());
//! peers.expire(t0 + Duration::from_secs(2));
//! assert!(peers.lines().is_empty(), "stale");
//! # Ok::<(), vr_app::cluster::ClusterError>(())
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::ClusterError;
use crate::scene::LineVertex;

/// The colour of another sculptor's wand (magenta: the own cursor is cyan or orange,
/// the footprint yellow, a live sketch green).
pub const PEER_WAND_COLOR: [f32; 4] = [1.0, 0.25, 0.85, 1.0];

/// Half the size of the cross drawn at another wand's tip (metres).
const CROSS: f64 = 0.02;
/// Length of the handle drawn from another wand's tip (metres).
const AXIS: f64 = 0.12;

/// One wand pose message: the body of `<session>.wand.<node>`, display frame metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WandPose {
    /// The tip, display frame.
    pub tip: [f64; 3],
    /// The wand's orientation (x, y, z, w); it points along its local -Z.
    pub q: [f64; 4],
    /// Whether the sculptor's stroke or sketch is live.
    pub active: bool,
}

impl WandPose {
    /// A pose message.
    pub fn new(tip: DVec3, q: DQuat, active: bool) -> Self {
        Self {
            tip: tip.to_array(),
            q: q.to_array(),
            active,
        }
    }

    /// The message's bytes (JSON).
    pub fn encode(&self) -> Result<Vec<u8>, ClusterError> {
        serde_json::to_vec(self).map_err(|cause| ClusterError::Encode {
            what: "a wand pose",
            cause,
        })
    }

    /// A pose from a message; `None` for anything else (bad JSON, not finite, not a
    /// rotation).
    pub fn decode(bytes: &[u8]) -> Option<Self> {
        let p: Self = serde_json::from_slice(bytes).ok()?;
        let q = DQuat::from_array(p.q);
        let finite = p.tip.iter().chain(&p.q).all(|v| v.is_finite());
        (finite && q.length_squared() > 0.0).then_some(p)
    }

    /// The tip and the pointing direction (unit), display frame.
    pub fn tip_and_axis(&self) -> (DVec3, DVec3) {
        let q = DQuat::from_array(self.q).normalize();
        (DVec3::from_array(self.tip), q * DVec3::NEG_Z)
    }
}

/// What a node heard of the other sculptors' wands (in its report).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Default)]
pub struct PeerWandStats {
    /// Wand poses published by this node.
    pub published: u64,
    /// Poses received from the owners drawn here.
    pub received: u64,
    /// Messages on the wand subjects that were not a configured owner's pose
    /// (counted and ignored).
    pub garbage: u64,
    /// Times a wand went stale and was no longer drawn.
    pub expired: u64,
    /// The owners whose wands were drawn at some time.
    pub seen: BTreeSet<String>,
}

/// The other sculptors' wands as one node sees them.
#[derive(Debug, Clone)]
pub struct PeerWands {
    /// The owners drawn here (owners on other feeds).
    drawn: BTreeSet<String>,
    /// The owners on this node's own feed (their wand is this node's own cursor).
    own_feed: BTreeSet<String>,
    stale: Duration,
    wands: BTreeMap<String, (WandPose, Instant)>,
    stats: PeerWandStats,
}

impl PeerWands {
    /// Draws the wands of `drawn` (owner names) and ignores those of `own_feed`; a
    /// wand not heard of for `stale` is dropped.
    pub fn new(
        drawn: impl IntoIterator<Item = String>,
        own_feed: impl IntoIterator<Item = String>,
        stale: Duration,
    ) -> Self {
        Self {
            drawn: drawn.into_iter().collect(),
            own_feed: own_feed.into_iter().collect(),
            stale,
            wands: BTreeMap::new(),
            stats: PeerWandStats::default(),
        }
    }

    /// Counts a pose this node published.
    pub fn published(&mut self) {
        self.stats.published += 1;
    }

    /// Takes one message from `node` (the subject's last token) received at `now`.
    /// Poses of the owners on this node's own feed are dropped; anything that is not a
    /// pose of a configured owner is garbage.
    pub fn take(&mut self, node: &str, payload: &[u8], now: Instant) {
        let Some(pose) = WandPose::decode(payload) else {
            self.stats.garbage += 1;
            return;
        };
        if !self.drawn.contains(node) {
            if !self.own_feed.contains(node) {
                self.stats.garbage += 1;
            }
            return;
        }
        self.stats.received += 1;
        self.stats.seen.insert(node.to_string());
        self.wands.insert(node.to_string(), (pose, now));
    }

    /// Drops the wands not heard of for the stale time before `now`.
    pub fn expire(&mut self, now: Instant) {
        let stale = self.stale;
        let before = self.wands.len();
        self.wands
            .retain(|_, (_, heard)| now.saturating_duration_since(*heard) < stale);
        self.stats.expired += (before - self.wands.len()) as u64;
    }

    /// The wands drawn now.
    pub fn current(&self) -> impl Iterator<Item = (&str, &WandPose)> {
        self.wands.iter().map(|(n, (p, _))| (n.as_str(), p))
    }

    /// The overlay lines of the wands drawn now: a cross at each tip and the wand's
    /// handle along its axis (twice as long while its sculptor's gesture is live), in
    /// [`PEER_WAND_COLOR`].
    pub fn lines(&self) -> Vec<LineVertex> {
        let mut out = Vec::new();
        for (_, pose) in self.current() {
            let (tip, axis) = pose.tip_and_axis();
            for d in [DVec3::X, DVec3::Y, DVec3::Z] {
                out.push(LineVertex::new(tip - d * CROSS, PEER_WAND_COLOR));
                out.push(LineVertex::new(tip + d * CROSS, PEER_WAND_COLOR));
            }
            let len = if pose.active { 2.0 * AXIS } else { AXIS };
            out.push(LineVertex::new(tip, PEER_WAND_COLOR));
            out.push(LineVertex::new(tip - axis * len, PEER_WAND_COLOR));
        }
        out
    }

    /// What was heard so far.
    pub fn stats(&self) -> PeerWandStats {
        self.stats.clone()
    }
}

/// One frame of a node: takes the wand messages received (`(node, payload)`), drops
/// the stale wands and hands the others to `app`'s overlay lines (drawn with its own
/// cursor by every renderer: headless, window, OpenXR).
pub fn show_peers(
    app: &mut crate::app::AppState,
    peers: &mut PeerWands,
    received: impl IntoIterator<Item = (String, Vec<u8>)>,
    now: Instant,
) {
    for (node, payload) in received {
        peers.take(&node, &payload, now);
    }
    peers.expire(now);
    app.peer_wand_lines = peers.lines();
}

/// Publishes at most `rate` times a second, and only a new sample.
#[derive(Debug, Clone)]
pub struct WandRate {
    period: Duration,
    next: Option<Instant>,
    last_sample: Option<f64>,
}

impl WandRate {
    /// At most `rate` (per second, positive) messages a second.
    pub fn new(rate: f64) -> Self {
        Self {
            period: Duration::from_secs_f64(1.0 / rate),
            next: None,
            last_sample: None,
        }
    }

    /// Whether the sample taken at `sample_t` (the wand's clock) is published at `now`;
    /// when so, the next one is due a period later.
    pub fn due(&mut self, sample_t: f64, now: Instant) -> bool {
        if self.last_sample == Some(sample_t) || self.next.is_some_and(|n| now < n) {
            return false;
        }
        self.last_sample = Some(sample_t);
        self.next = Some(now + self.period);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, active: bool) -> Vec<u8> {
        WandPose::new(DVec3::new(x, 1.2, 0.3), DQuat::IDENTITY, active)
            .encode()
            .unwrap()
    }

    #[test]
    fn another_owners_wand_is_drawn_in_its_colour_until_it_goes_stale() {
        let t0 = Instant::now();
        let stale = Duration::from_secs(1);
        let mut peers = PeerWands::new(["desk".to_string()], [], stale);
        assert!(peers.lines().is_empty());
        peers.take("desk", &pose(0.1, false), t0);
        let lines = peers.lines();
        // A cross (three segments) and the axis.
        assert_eq!(lines.len(), 8);
        assert!(lines.iter().all(|v| v.color == PEER_WAND_COLOR));
        let tip = DVec3::new(0.1, 1.2, 0.3).as_vec3().to_array();
        assert_eq!(lines[6].position, tip, "the axis starts at the tip");
        // The identity wand points along -Z; the line is its handle, behind the tip,
        // as the own cursor draws it.
        assert!(lines[7].position[2] > tip[2]);
        // Heard again at 0.9 s: still drawn at 1.5 s, gone at 2 s.
        peers.take("desk", &pose(0.2, true), t0 + Duration::from_millis(900));
        peers.expire(t0 + Duration::from_millis(1500));
        assert_eq!(peers.current().count(), 1);
        peers.expire(t0 + Duration::from_millis(1900));
        assert!(peers.lines().is_empty());
        let s = peers.stats();
        assert_eq!((s.received, s.expired, s.garbage), (2, 1, 0));
        assert!(s.seen.contains("desk"));
    }

    #[test]
    fn the_other_wand_is_in_the_nodes_overlay_lines_until_it_is_stale() {
        let dir = tempfile::tempdir().unwrap();
        let mut config = crate::config::Config::default();
        config.files.dir = dir.path().to_path_buf();
        let mut app = crate::app::AppState::new(config).unwrap();
        let own = app.overlay_lines();
        let t0 = Instant::now();
        let mut peers = PeerWands::new(["desk".to_string()], [], Duration::from_secs(1));
        let msg = ("desk".to_string(), pose(0.05, false));
        show_peers(&mut app, &mut peers, [msg], t0);
        let drawn = app.overlay_lines();
        let peer: Vec<&LineVertex> = drawn
            .iter()
            .filter(|v| v.color == PEER_WAND_COLOR)
            .collect();
        assert_eq!(peer.len(), 8, "{drawn:?}");
        assert_eq!(drawn.len(), own.len() + 8);
        let tip = DVec3::new(0.05, 1.2, 0.3).as_vec3().to_array();
        assert!(peer.iter().any(|v| v.position == tip));
        // Nothing heard for a second: gone from the overlay.
        show_peers(&mut app, &mut peers, [], t0 + Duration::from_secs(1));
        assert_eq!(app.overlay_lines(), own);
    }

    #[test]
    fn garbage_and_own_feed_owners_are_not_drawn() {
        let t0 = Instant::now();
        let mut peers = PeerWands::new(
            ["desk".to_string()],
            ["wall".to_string()],
            Duration::from_secs(1),
        );
        peers.take("desk", b"\x00garbage {]", t0);
        peers.take(
            "desk",
            br#"{"tip":[1e999,0,0],"q":[0,0,0,1],"active":false}"#,
            t0,
        );
        peers.take(
            "desk",
            br#"{"tip":[0,0,0],"q":[0,0,0,0],"active":false}"#,
            t0,
        );
        // The owner on this node's own feed: its cursor is this node's own.
        peers.take("wall", &pose(0.0, false), t0);
        // Not a configured owner.
        peers.take("intruder", &pose(0.0, false), t0);
        assert!(peers.lines().is_empty());
        assert_eq!(peers.stats().garbage, 4);
        assert_eq!(peers.stats().received, 0);
    }

    #[test]
    fn the_rate_limit_passes_new_samples_at_most_once_a_period() {
        let t0 = Instant::now();
        let mut rate = WandRate::new(30.0);
        assert!(rate.due(0.0, t0));
        assert!(
            !rate.due(0.0, t0 + Duration::from_millis(50)),
            "same sample"
        );
        assert!(!rate.due(0.01, t0 + Duration::from_millis(10)), "too soon");
        assert!(rate.due(0.02, t0 + Duration::from_millis(34)));
        // A 100 Hz wand over one second: 30 messages, give or take the phase.
        let mut rate = WandRate::new(30.0);
        let sent = (0..100)
            .filter(|&i: &u32| {
                rate.due(
                    f64::from(i) * 0.01,
                    t0 + Duration::from_millis(10 * u64::from(i)),
                )
            })
            .count();
        assert!((25..=34).contains(&sent), "{sent}");
    }
}
