//! The node's loop: start (connect, subscribe, catch up), one turn per frame, the
//! swap lock, and the end of the session.

use std::sync::atomic::Ordering;
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use async_nats::jetstream;
use futures_util::StreamExt;

use super::feed::{FeedStats, follow_feed};
use super::replica::Snapshots;
use super::replica::{Node, NodeSink};
use super::report::{NodeReport, SnapshotReport};
use super::snapshots::{StreamCheck, snapshot_writer};
use super::stream::{follow_stream, open_stream};
use super::{NodeOptions, READY_FILE};
use crate::app::AppState;
use crate::cluster::barrier::Barrier;
use crate::cluster::snapshot::OpsHash;
use crate::cluster::wand::{PeerWands, WandPose, WandRate, show_peers};
use crate::cluster::{
    ClusterConfigError, ClusterError, ClusterSection, KIND_END, NatsFailure, NodeSection,
    Percentiles, unix_ns,
};
use crate::config::Config;
use crate::error::VrResult;
use crate::feeder::Feeder;
use crate::headless::{HeadlessOptions, run_headless};
use crate::input::Input;
use crate::live::LiveTracking;
use crate::render::Gpu;

/// A running node, from its start (connected, subscribed, caught up with the stream)
/// to its end. Its drivers call [`NodeLoop::step`] every turn and [`NodeLoop::swap_lock`]
/// between drawing a frame and presenting it: the headless one ([`run_node`]) and the
/// window's (`window::run_windowed_node` (feature `window`)), whose presentation of frame N
/// waits until every live node has frame N ready.
pub struct NodeLoop {
    node: Node,
    live: LiveTracking,
    /// The feed's raw frames to wand events, as every driver does it.
    feeder: Feeder,
    client: async_nats::Client,
    cluster: ClusterSection,
    me: NodeSection,
    barrier: Option<Barrier>,
    peers: PeerWands,
    wand_rate: WandRate,
    wand_subject: String,
    wand_rx: mpsc::Receiver<(String, Vec<u8>)>,
    feed: Arc<FeedStats>,
    started: Instant,
    idle_exit: f64,
    duration: f64,
    frame_dt: Duration,
    next_frame: Instant,
    frame_no: u64,
    last_t: f64,
    ended: bool,
    backlog: u64,
    catch_up_s: f64,
    propagation_ms: Vec<f64>,
    presented: u64,
}

impl std::fmt::Debug for NodeLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NodeLoop")
            .field("node", &self.me.name)
            .field("owner", &self.node.owner)
            .field("frame", &self.frame_no)
            .finish_non_exhaustive()
    }
}

/// Runs a headless node until every owner's session has ended (or `duration`
/// passes), then writes its document and its screen's pictures.
pub fn run_node(config: Config, opts: &NodeOptions, gpu: &Gpu) -> VrResult<NodeReport> {
    let (mut node, mut app) = NodeLoop::start(config, opts)?;
    while !node.step(&mut app)? {
        if node.barrier.is_some() {
            let now = Instant::now();
            if now < node.next_frame {
                std::thread::sleep((node.next_frame - now).min(Duration::from_millis(2)));
                continue;
            }
            node.swap_lock()?;
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    node.finish(&mut app, gpu, &opts.headless)
}

impl NodeLoop {
    /// Connects, finds (or creates) the operation stream, loads the latest good
    /// snapshot, subscribes to the feed, the barrier and the wands, and applies the
    /// stream's backlog; then writes [`READY_FILE`]. Returns the node and the display
    /// state its documents live in.
    pub fn start(mut config: Config, opts: &NodeOptions) -> VrResult<(Self, AppState)> {
        let cluster: ClusterSection = config
            .cluster
            .clone()
            .ok_or(ClusterError::Config(ClusterConfigError::NoSection))?;
        cluster.validate()?;
        let me = cluster.node(&opts.name)?.clone();
        let subjects = cluster.subjects();
        let mut section = config
            .tracking
            .clone()
            .ok_or(ClusterError::Config(ClusterConfigError::NoTracking))?;
        // The feed is the node's only source; the configured ones are the ingest's.
        section.input.sources.clear();
        section.playback = None;
        let mut live = LiveTracking::start(&section)?;
        let feeder = Feeder::new(
            section.stage_config()?,
            config.interaction.pause_timeout,
            section.thumbstick,
        )?;
        let (hub, feed_src) = live.add_feed(&format!("nats:{}", me.feed));
        let rt = crate::cluster::runtime("wandsculpt-cluster")?;
        let started = Instant::now();
        let credentials = cluster.node_credentials(&me, &opts.credentials);
        let client = rt.block_on(cluster.connect(
            &format!("wandsculpt-{}", me.name),
            &credentials,
            &crate::cluster::ServerRefusals::default(),
        ))?;
        let js = jetstream::new(client.clone());
        let jserr =
            |what: &'static str| move |e: NatsFailure| ClusterError::JetStream { what, source: e };
        let commit_timeout = Duration::from_secs_f64(cluster.commit_timeout);
        let (ops_stream, stream_last, stream_id) =
            open_stream(&rt, &js, &subjects, me.owner, commit_timeout)?;

        // The latest snapshot, when there is a good one (checked against the stream):
        // its document becomes the base scene and the stream is followed from the
        // position after it.
        let base_scene = config.files.scene.clone();
        let (snap_store, loaded, snap_report) = if cluster.snapshots {
            StreamCheck {
                rt: &rt,
                cluster: &cluster,
                ops_stream: &ops_stream,
                stream_id,
                last: stream_last,
                wait: commit_timeout,
            }
            .latest(&js, me.owner, &mut config.files)
        } else {
            (None, None, SnapshotReport::default())
        };
        let start_seq = loaded.as_ref().map_or(0, |r| r.seq);
        let backlog = stream_last.saturating_sub(start_seq);
        let mut app = AppState::new(config.clone())?;

        // The operation stream, in order, from the position after the snapshot.
        let (ops_tx, ops_rx) = mpsc::channel();
        rt.spawn(follow_stream(
            ops_stream.clone(),
            subjects.ops.clone(),
            start_seq + 1,
            ops_tx,
        ));

        // The tracking feed into this node's hub.
        let feed = follow_feed(&rt, &client, subjects.tracking(&me.feed), hub, feed_src)
            .map_err(|e| jserr("tracking subscription")(e.into()))?;

        // The frame barrier.
        let barrier = if cluster.barrier {
            let (tx, rx) = mpsc::channel();
            let mut sub = rt
                .block_on(client.subscribe(subjects.barrier.clone()))
                .map_err(|e| jserr("barrier subscription")(e.into()))?;
            rt.spawn(async move {
                while let Some(msg) = sub.next().await {
                    if tx.send(msg.payload.to_vec()).is_err() {
                        break;
                    }
                }
            });
            let names: Vec<String> = cluster.nodes.iter().map(|n| n.name.clone()).collect();
            Some(Barrier::new(
                &me.name,
                &names,
                Duration::from_secs_f64(cluster.barrier_timeout),
                rx,
            ))
        } else {
            None
        };
        // The other sculptors' wands.
        let (wand_tx, wand_rx) = mpsc::channel::<(String, Vec<u8>)>();
        let mut wand_sub = rt
            .block_on(client.subscribe(subjects.wands.clone()))
            .map_err(|e| jserr("wand subscription")(e.into()))?;
        rt.spawn(async move {
            while let Some(msg) = wand_sub.next().await {
                let node = msg
                    .subject
                    .rsplit('.')
                    .next()
                    .unwrap_or_default()
                    .to_string();
                if wand_tx.send((node, msg.payload.to_vec())).is_err() {
                    break;
                }
            }
        });
        let (own_feed, other_feeds): (Vec<&NodeSection>, Vec<&NodeSection>) = cluster
            .nodes
            .iter()
            .filter(|n| n.owner)
            .partition(|n| n.feed == me.feed);
        let peers = PeerWands::new(
            other_feeds.iter().map(|n| n.name.clone()),
            own_feed.iter().map(|n| n.name.clone()),
            Duration::from_secs_f64(cluster.wand_stale),
        );
        let wand_rate = WandRate::new(cluster.wand_rate);
        let wand_subject = subjects.wand(&me.name);

        rt.block_on(client.flush())
            .map_err(|e| jserr("flush")(e.into()))?;

        let mut node = Node {
            rt,
            js,
            subjects: subjects.clone(),
            name: me.name.clone(),
            owner: me.owner,
            owners: cluster.owners().into_iter().collect(),
            commit_timeout,
            run_id: unix_ns(),
            proposed: 0,
            ops: ops_rx,
            applied_seq: start_seq,
            applied: 0,
            committed: 0,
            garbage_ops: 0,
            refused_ops: 0,
            chain: loaded.as_ref().map_or(OpsHash::EMPTY, |r| r.ops_hash),
            last_op_seq: start_seq,
            ends: loaded
                .as_ref()
                .map(|r| r.ends.iter().cloned().collect())
                .unwrap_or_default(),
            commit_ms: Vec::new(),
            apply_ms: Vec::new(),
            apply_by_seq: Vec::new(),
            snap: Snapshots {
                store: snap_store,
                session: cluster.session.clone(),
                stream: stream_id,
                ops_stream,
                every: cluster.snapshot_every,
                loaded: loaded.as_ref().map(|r| r.seq),
                base_scene,
                writing: None,
                report: snap_report,
            },
        };
        drop(loaded);
        // Catch up with the stream before following the feed.
        node.wait_applied(
            &mut app,
            stream_last,
            started + Duration::from_secs_f64(opts.duration),
        )?;
        let catch_up_s = started.elapsed().as_secs_f64();
        tracing::info!(node = %me.name, backlog, catch_up_s, "caught up with the operation stream");
        crate::session::write_atomic(
            &app.session.dir().join(READY_FILE),
            format!("{}\n", me.name).as_bytes(),
        )?;

        let frame_dt = Duration::from_secs_f64(1.0 / cluster.frame_rate);
        let me_section = me.clone();
        Ok((
            Self {
                node,
                live,
                feeder,
                client,
                cluster,
                me: me_section,
                barrier,
                peers,
                wand_rate,
                wand_subject,
                wand_rx,
                feed,
                started,
                idle_exit: opts.idle_exit,
                duration: opts.duration,
                frame_dt,
                next_frame: Instant::now(),
                frame_no: 0,
                last_t: 0.0,
                ended: false,
                backlog,
                catch_up_s,
                propagation_ms: Vec::new(),
                presented: 0,
            },
            app,
        ))
    }

    /// Whether this node's interaction proposes edits.
    pub fn owner(&self) -> bool {
        self.node.owner
    }

    /// One turn: the tracking feed's new samples through the interaction (an owner
    /// commits the edits it proposes), the stream's new operations, the other
    /// sculptors' wands, a snapshot when due, and the owner's end of session. Returns
    /// `true` once the session is over for this node (every owner has ended, or the
    /// duration passed).
    pub fn step(&mut self, app: &mut AppState) -> VrResult<bool> {
        let inputs = self.live.poll();
        let mut sink = NodeSink {
            node: &mut self.node,
            app,
            last_t: &mut self.last_t,
        };
        self.feeder.feed_all(&inputs, &mut sink)?;
        self.note_propagation();
        self.node.drain(app)?;
        let now = Instant::now();
        show_peers(app, &mut self.peers, self.wand_rx.try_iter(), now);
        if self.node.owner
            && !self.ended
            && let Some((t, tip, q)) = app.session.interaction.wand()
            && self.wand_rate.due(t, now)
        {
            let active = app.session.interaction.gesture_active();
            let body = WandPose::new(tip, q, active).encode()?;
            // Best effort, as tracking frames: a lost pose is followed by the next.
            if let Err(e) = self
                .node
                .rt
                .block_on(self.client.publish(self.wand_subject.clone(), body.into()))
            {
                tracing::debug!("publishing the wand pose: {e}");
            } else {
                self.peers.published();
            }
        }
        if snapshot_writer(&self.node, &self.cluster, self.barrier.as_ref()) {
            self.node.snapshot(app, false);
        }
        let idle = self
            .live
            .last_report()
            .is_some_and(|l| self.live.now().saturating_sub(l).as_secs_f64() > self.idle_exit);
        let timed_out = self.started.elapsed().as_secs_f64() > self.duration;
        if self.live.sources_done() || idle || timed_out {
            self.end_session(app)?;
        }
        if !self.node.owners.is_empty() && self.node.owners.is_subset(&self.node.ends) {
            return Ok(true);
        }
        if timed_out {
            tracing::warn!(node = %self.me.name, "duration passed before every owner ended");
            return Ok(true);
        }
        Ok(false)
    }

    /// An owner ends its session: past the last input a stroke paused by tracking loss
    /// ends, then its end marker goes into the stream (once; other nodes do nothing).
    fn end_session(&mut self, app: &mut AppState) -> VrResult<()> {
        if !self.node.owner || self.ended {
            return Ok(());
        }
        let t = self.last_t + 10.0;
        let edits = app.session.propose_tick(t)?;
        self.node.commit(app, t, edits)?;
        let deadline = Instant::now() + self.node.commit_timeout;
        let seq = self.node.publish(KIND_END, Vec::new(), deadline)?;
        self.node.wait_applied(app, seq, deadline)?;
        self.ended = true;
        Ok(())
    }

    /// Propagation of the frames the last poll staged: from the ingest receiving each
    /// frame from the tracker to this node's stage taking it.
    fn note_propagation(&mut self) {
        let Some((node_at, unix_at)) = self.feed.clock.lock().ok().and_then(|b| *b) else {
            return;
        };
        let now = unix_ns();
        for &received in self.live.staged() {
            let since = received.saturating_sub(node_at).as_nanos();
            let unix = unix_at.saturating_add(u64::try_from(since).unwrap_or(u64::MAX));
            self.propagation_ms
                .push(now.saturating_sub(unix) as f64 / 1e6);
        }
    }

    /// Frame lock and software swap lock: reports this node's current frame ready
    /// and waits until every live node has reported it (or the barrier's timeout drops
    /// the late ones); the caller presents the frame after this returns. Without a
    /// barrier it returns at once.
    pub fn swap_lock(&mut self) -> VrResult<()> {
        let Some(b) = self.barrier.as_mut() else {
            self.presented += 1;
            return Ok(());
        };
        let report = b.report(self.frame_no)?;
        let subject = self.node.subjects.barrier.clone();
        self.node
            .rt
            .block_on(self.client.publish(subject.clone(), report.into()))
            .map_err(|e| ClusterError::Publish {
                subject,
                source: e.into(),
            })?;
        self.frame_no = b.wait(self.frame_no);
        self.next_frame = (self.next_frame + self.frame_dt).max(Instant::now());
        self.presented += 1;
        Ok(())
    }

    /// A command from the node's own keys (undo, a mode, the tool): an owner commits
    /// its edits through the stream like the wand's; on any other node it changes
    /// nothing (its document follows the stream only).
    pub fn command(
        &mut self,
        app: &mut AppState,
        ev: &sculpt_core::interaction::WandEvent,
    ) -> VrResult<()> {
        if !self.node.owner {
            tracing::info!(node = %self.me.name, "not an owner: edits come from the stream only");
            return Ok(());
        }
        let mut sink = NodeSink {
            node: &mut self.node,
            app,
            last_t: &mut self.last_t,
        };
        self.feeder
            .feed(&Input::Wand(ev.clone()), &mut sink)
            .map(drop)
    }

    /// Ends the session: a non-owner's interaction ends a paused gesture, the
    /// snapshot writer stores the last snapshot, and the document and this screen's
    /// pictures are written (with `gpu`, as a headless run writes them).
    pub fn finish(
        mut self,
        app: &mut AppState,
        gpu: &Gpu,
        pictures: &HeadlessOptions,
    ) -> VrResult<NodeReport> {
        // An owner whose window closed before its feed ended ends its session now,
        // so the other nodes need not wait for `--duration`. Not an owner: the
        // interaction, too, ends a paused gesture (its edits are the owner's to
        // commit, and are already in the stream).
        if self.node.owner {
            self.end_session(app)?;
        } else {
            app.session.propose_tick(self.last_t + 10.0)?;
        }
        // The writer's last snapshot covers the whole session (a clean exit).
        if snapshot_writer(&self.node, &self.cluster, self.barrier.as_ref()) {
            self.node.snapshot(app, true);
        }
        let Self {
            mut node,
            live,
            barrier,
            peers,
            feed,
            backlog,
            catch_up_s,
            mut propagation_ms,
            presented,
            me,
            ..
        } = self;
        drop(live);
        let headless = run_headless(app, gpu, std::iter::empty(), pictures)?;
        Ok(NodeReport {
            node: me.name.clone(),
            owner: me.owner,
            headless,
            applied: node.applied,
            committed: node.committed,
            backlog,
            catch_up_s,
            snapshot: node.snap.report.clone(),
            peer_wands: peers.stats(),
            garbage_ops: node.garbage_ops,
            refused_ops: node.refused_ops,
            garbage_frames: feed.garbage.load(Ordering::Relaxed),
            frames: feed.frames.load(Ordering::Relaxed),
            propagation_ms: Percentiles::of(&mut propagation_ms),
            commit_ms: Percentiles::of(&mut node.commit_ms),
            apply_ms: Percentiles::of(&mut node.apply_ms),
            apply_by_seq: std::mem::take(&mut node.apply_by_seq),
            presented,
            windowed: false,
            ended_owners: node.ends.iter().cloned().collect(),
            barrier: barrier.map(|mut b| b.stats()),
        })
    }
}
