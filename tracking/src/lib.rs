//! # tracking
//!
//! Wand and head poses for Wandsculpt: DTrack2 ASCII over TCP and UDP, serial wands,
//! filtering, tracking-loss handling, calibration, pose logs and a tracker simulator.
//! Codecs are pure (bytes in, frames out); tokio lives only at the transport edges.
