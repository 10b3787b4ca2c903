//! A node's tracking feed: the ingest's frames from NATS into the node's own hub,
//! on the ingest's clock.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures_util::StreamExt;
use tracking::hub::{Hub, SourceId};

use crate::cluster::{HDR_KIND, HDR_POSE, HDR_RECEIVED, HDR_RECEIVED_UNIX, KIND_END, header};

/// Counters the tracking task shares with the node loop.
#[derive(Debug, Default)]
pub(super) struct FeedStats {
    pub(super) frames: AtomicU64,
    pub(super) garbage: AtomicU64,
    /// [`FeedClock::base`]: to turn a staged frame's receive time into the Unix time
    /// the ingest received it.
    pub(super) clock: Mutex<Option<(Duration, u64)>>,
}

/// How far ahead of this node's clock a feed frame's receive time may be before
/// [`FeedClock`] starts a new base.
pub(super) const FEED_CLOCK_AHEAD: Duration = Duration::from_secs(1);
/// How far behind (a node held up, then catching up on buffered frames).
pub(super) const FEED_CLOCK_BEHIND: Duration = Duration::from_secs(30);

/// The receive times a node gives the feed's frames: the ingest's (its hub clock,
/// [`HDR_RECEIVED`]), moved onto this node's hub clock at the first frame. So every
/// node's stage sees the same intervals between frames as the ingest's did (the stage
/// reads them where frames carry no timestamp), whatever the network did to them.
#[derive(Debug, Default)]
pub(super) struct FeedClock {
    /// The ingest's receive time and this node's hub time at the first frame, and the
    /// Unix time the ingest received it ([`HDR_RECEIVED_UNIX`]), if sent.
    pub(super) base: Option<(Duration, Duration, Option<u64>)>,
    /// The ingest's receive time of the last frame.
    pub(super) last: Option<Duration>,
}

impl FeedClock {
    /// The receive time of a frame that arrives at `now` (this node's hub clock) with
    /// the ingest's receive time `ingest_us` and its Unix time `ingest_unix_ns`. A frame
    /// without the ingest's time is stamped `now`; an ingest whose clock went back (a
    /// new ingest process) starts a new base.
    pub(super) fn receive_time(
        &mut self,
        now: Duration,
        ingest_us: Option<u64>,
        ingest_unix_ns: Option<u64>,
    ) -> Duration {
        let Some(us) = ingest_us else {
            return now;
        };
        let ingest = Duration::from_micros(us);
        if self.last.is_some_and(|l| ingest < l) {
            self.base = None;
        }
        self.last = Some(ingest);
        let (ingest0, node0, _) = *self.base.get_or_insert((ingest, now, ingest_unix_ns));
        let t = node0 + ingest.saturating_sub(ingest0);
        // A time far from this node's own clock (a hostile or broken peer, a new
        // ingest whose clock happens to be ahead): start a new base at this frame.
        if t > now + FEED_CLOCK_AHEAD || t + FEED_CLOCK_BEHIND < now {
            self.base = Some((ingest, now, ingest_unix_ns));
            return now;
        }
        t
    }

    /// This node's hub time of the first frame and the Unix time the ingest received
    /// it, when it said.
    pub(super) fn base(&self) -> Option<(Duration, u64)> {
        let (_, node0, unix0) = self.base?;
        Some((node0, unix0?))
    }
}

/// Subscribes to the feed's `subject` and hands its frames to `hub` as source
/// `feed_src`, on the ingest's clock ([`FeedClock`]); an end marker closes the source.
/// Returns the counters the task keeps.
pub(super) fn follow_feed(
    rt: &tokio::runtime::Runtime,
    client: &async_nats::Client,
    subject: String,
    hub: Hub,
    feed_src: SourceId,
) -> Result<Arc<FeedStats>, async_nats::SubscribeError> {
    let feed = Arc::new(FeedStats::default());
    let mut tracking_sub = rt.block_on(client.subscribe(subject))?;
    let feed_stats = feed.clone();
    rt.spawn(async move {
        let mut opened = false;
        let mut clock = FeedClock::default();
        while let Some(msg) = tracking_sub.next().await {
            if header(&msg, HDR_KIND) == Some(KIND_END) {
                if opened {
                    hub.connection_closed(feed_src, hub.now());
                }
                continue;
            }
            match tracking::dtrack::parse_frame(&msg.payload) {
                Ok(mut frame) => {
                    if !opened {
                        hub.connection_opened(feed_src);
                        opened = true;
                    }
                    let ingest_us = header(&msg, HDR_RECEIVED).and_then(|s| s.parse().ok());
                    let ingest_unix = header(&msg, HDR_RECEIVED_UNIX).and_then(|s| s.parse().ok());
                    frame.receive_time = clock.receive_time(hub.now(), ingest_us, ingest_unix);
                    let pose = header(&msg, HDR_POSE) != Some("0");
                    hub.apply(feed_src, &frame, pose);
                    feed_stats.frames.fetch_add(1, Ordering::Relaxed);
                    if let Ok(mut base) = feed_stats.clock.lock() {
                        *base = clock.base();
                    }
                }
                Err(e) => {
                    feed_stats.garbage.fetch_add(1, Ordering::Relaxed);
                    tracing::debug!("ignoring a tracking message that is not a frame: {e}");
                }
            }
        }
    });
    Ok(feed)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn the_feed_keeps_the_ingests_intervals_on_the_nodes_clock() {
        let mut c = FeedClock::default();
        assert_eq!(c.base(), None);
        // First frame: received by the ingest at 5 s, here at 1 s (node clock).
        assert_eq!(
            c.receive_time(1000 * MS, Some(5_000_000), Some(77)),
            1000 * MS
        );
        assert_eq!(c.base(), Some((1000 * MS, 77)));
        // 10 ms later at the ingest; the network delayed it by 7 ms more than the
        // first: the stage still sees 10 ms.
        assert_eq!(c.receive_time(1017 * MS, Some(5_010_000), None), 1010 * MS);
        // A frame without the ingest's time is stamped on arrival.
        assert_eq!(c.receive_time(1030 * MS, None, None), 1030 * MS);
        // A new ingest (its clock went back): a new base.
        assert_eq!(c.receive_time(2000 * MS, Some(1_000), Some(99)), 2000 * MS);
        assert_eq!(c.base(), Some((2000 * MS, 99)));
        // A time an hour ahead of the node's clock (a hostile peer): a new base, and
        // the frame is stamped on arrival.
        assert_eq!(
            c.receive_time(2010 * MS, Some(3_600_000_000), Some(5)),
            2010 * MS
        );
        assert_eq!(c.base(), Some((2010 * MS, 5)));
        assert_eq!(
            c.receive_time(2030 * MS, Some(3_600_010_000), None),
            2020 * MS
        );
        // The largest time the header can carry: no overflow, a new base.
        assert_eq!(c.receive_time(2040 * MS, Some(u64::MAX), None), 2040 * MS);
    }
}
