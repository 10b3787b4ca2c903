//! The hub's frame subscription: every accepted frame, in order, with its source;
//! out-of-order frames are not sent, and a subscriber that falls behind counts what it
//! lost instead of blocking the hub.

use glam::DVec3;
use tracking::config::TrackingConfig;
use tracking::hub::{FRAME_CAPACITY, Hub};
use tracking::{Frame, Pose, Wand};

fn frame(n: u64, x_mm: f64) -> Frame {
    let mut f = Frame::new(n);
    f.tracker_time = Some(n as f64 / 60.0);
    f.receive_time = std::time::Duration::from_millis(n * 16);
    f.wands.push(Wand::tracked(
        0,
        Pose::from_position_mm(DVec3::new(x_mm, 1000.0, 0.0)),
    ));
    f
}

#[test]
fn every_accepted_frame_arrives_in_order_with_its_source() {
    let hub = Hub::new(&TrackingConfig::default());
    let a = hub.add_source("a");
    let b = hub.add_source("b");
    let mut sub = hub.subscribe_frames();
    // Many frames between two polls: a latest-value watch would keep only the last.
    for n in 1..=200u64 {
        assert!(hub.apply_frame(if n.is_multiple_of(2) { a } else { b }, &frame(n, n as f64)));
    }
    // A stale frame from `a` is dropped by the hub and not sent.
    assert!(!hub.apply_frame(a, &frame(150, 0.0)));
    let mut got = Vec::new();
    while let Some(f) = sub.try_recv() {
        got.push(f);
    }
    assert_eq!(got.len(), 200);
    for (k, f) in got.iter().enumerate() {
        let n = k as u64 + 1;
        assert_eq!(f.frame, frame(n, n as f64));
        assert_eq!(f.source, if n.is_multiple_of(2) { a } else { b });
        assert!(f.carries_pose);
    }
    assert_eq!(sub.dropped(), 0);
}

#[test]
fn a_subscriber_that_falls_behind_counts_its_losses_and_resumes_in_order() {
    let hub = Hub::new(&TrackingConfig::default());
    let src = hub.add_source("a");
    let mut sub = hub.subscribe_frames();
    let total = FRAME_CAPACITY as u64 + 10;
    for n in 1..=total {
        hub.apply_frame(src, &frame(n, 0.0));
    }
    let first = sub.try_recv().unwrap();
    assert_eq!(sub.dropped(), 10);
    assert_eq!(
        first.frame.number, 11,
        "the oldest frames were the ones lost"
    );
    let mut last = first.frame.number;
    while let Some(f) = sub.try_recv() {
        assert_eq!(f.frame.number, last + 1);
        last = f.frame.number;
    }
    assert_eq!(last, total);
}

#[test]
fn async_receive_ends_when_the_hub_is_gone() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap();
    let hub = Hub::new(&TrackingConfig::default());
    let src = hub.add_source("a");
    let mut sub = hub.subscribe_frames();
    hub.apply_frame(src, &frame(1, 5.0));
    drop(hub);
    rt.block_on(async {
        assert_eq!(sub.recv().await.unwrap().frame.number, 1);
        assert!(sub.recv().await.is_none());
    });
}
