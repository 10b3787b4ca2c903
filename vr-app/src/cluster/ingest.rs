//! The ingest role: reads the tracker (the `[tracking]` sources, as a display server
//! does) and publishes every frame received, in arrival order, on
//! `<session>.tracking.<feed>`: the DTrack2 ASCII of the frame as the body, its receive
//! time and send time in headers. When every source has served the session and gone,
//! an end marker follows.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use async_nats::HeaderMap;
use tracking::hub::{Hub, SourcedFrame};
use tracking::transport;

use super::{
    ClusterError, ClusterSection, HDR_KIND, HDR_POSE, HDR_RECEIVED, HDR_RECEIVED_UNIX, HDR_SENT,
    KIND_END, KIND_FRAME, unix_ns,
};
use crate::config::TrackingSection;
use crate::error::{VrError, VrResult};

/// Options of an ingest run.
#[derive(Debug, Clone, PartialEq)]
pub struct IngestOptions {
    /// The feed published (`<session>.tracking.<feed>`).
    pub feed: String,
    /// Stop this many seconds after the last frame (once one arrived).
    pub idle_exit: f64,
    /// Stop after this many seconds in any case.
    pub duration: f64,
    /// Write the bound addresses of listening sources here.
    pub addr_file: Option<std::path::PathBuf>,
    /// Credentials from the command line, replacing the config's.
    pub credentials: super::auth::Credentials,
}

/// What an ingest run did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct IngestReport {
    /// Frames published.
    pub frames: u64,
    /// The subject.
    pub subject: String,
}

/// Runs the ingest role until the tracker has served the session and gone (or the
/// idle or duration limit passes), then publishes the end marker.
pub fn run_ingest(
    cluster: &ClusterSection,
    section: &TrackingSection,
    opts: &IngestOptions,
) -> VrResult<IngestReport> {
    cluster.validate()?;
    let runtime = super::runtime("wandsculpt-ingest")?;
    runtime.block_on(ingest(cluster, section, opts))
}

/// The headers of a published frame: its receive time on the ingest's hub clock (the
/// nodes' stages use it) and as Unix time, and the send time (the latency figures).
fn frame_headers(f: &SourcedFrame, hub: &Hub) -> HeaderMap {
    let mut headers = HeaderMap::new();
    headers.insert(HDR_KIND, KIND_FRAME);
    headers.insert(
        HDR_RECEIVED,
        f.frame.receive_time.as_micros().to_string().as_str(),
    );
    let sent = unix_ns();
    let ago = hub.now().saturating_sub(f.frame.receive_time).as_nanos();
    let received = sent.saturating_sub(u64::try_from(ago).unwrap_or(u64::MAX));
    headers.insert(HDR_RECEIVED_UNIX, received.to_string().as_str());
    headers.insert(HDR_SENT, sent.to_string().as_str());
    if !f.carries_pose {
        headers.insert(HDR_POSE, "0");
    }
    headers
}

async fn ingest(
    cluster: &ClusterSection,
    section: &TrackingSection,
    opts: &IngestOptions,
) -> VrResult<IngestReport> {
    let refused = super::ServerRefusals::default();
    let client = cluster
        .connect(
            "wandsculpt-ingest",
            &cluster.ingest_credentials(&opts.credentials),
            &refused,
        )
        .await?;
    let subject = cluster.subjects().tracking(&opts.feed);
    let hub = Hub::new(&section.input);
    let mut frames = hub.subscribe_received();
    let running = transport::start_with_hub(hub.clone(), &section.input)
        .await
        .map_err(|reason| VrError::Tracking {
            what: "tracking".into(),
            reason: Box::new(reason),
        })?;
    let bound: Vec<String> = running
        .local_addrs
        .iter()
        .flatten()
        .map(ToString::to_string)
        .collect();
    for a in &bound {
        tracing::info!("ingest listening on {a}");
    }
    if let Some(path) = &opts.addr_file {
        let text: String = bound.iter().map(|a| format!("{a}\n")).collect();
        crate::session::write_atomic(path, text.as_bytes())?;
    }
    let wand_id = section.stage_config()?.wand_id;
    let started = Instant::now();
    let mut served = BTreeSet::new();
    let mut last = None::<Instant>;
    let mut count = 0u64;
    let mut body = Vec::new();
    let publish_err = |e: async_nats::PublishError| ClusterError::Publish {
        subject: subject.clone(),
        source: e.into(),
    };
    loop {
        match tokio::time::timeout(Duration::from_millis(20), frames.recv()).await {
            Ok(Some(f)) => {
                body.clear();
                tracking::dtrack::encode_frame(&f.frame, &mut body);
                client
                    .publish_with_headers(
                        subject.clone(),
                        frame_headers(&f, &hub),
                        body.clone().into(),
                    )
                    .await
                    .map_err(publish_err)?;
                count += 1;
                last = Some(Instant::now());
                if f.frame.wand(wand_id).is_some() {
                    served.insert(f.source);
                }
                continue;
            }
            Ok(None) => break,
            Err(_elapsed) => {}
        }
        let gone = last.is_some()
            && running.sources.iter().all(|&s| {
                served.contains(&s)
                    && hub
                        .source_stats(s)
                        .is_some_and(|st| st.connections > 0 && !st.connected)
            });
        let idle = last.is_some_and(|l| l.elapsed().as_secs_f64() > opts.idle_exit);
        let timed_out = started.elapsed().as_secs_f64() > opts.duration;
        if gone || idle || timed_out {
            // Frames that arrived before the sources went are already queued.
            let mut drained = 0;
            while let Some(f) = frames.try_recv() {
                body.clear();
                tracking::dtrack::encode_frame(&f.frame, &mut body);
                client
                    .publish_with_headers(
                        subject.clone(),
                        frame_headers(&f, &hub),
                        body.clone().into(),
                    )
                    .await
                    .map_err(publish_err)?;
                drained += 1;
            }
            count += drained;
            tracing::info!(
                sources_gone = gone,
                idle,
                timed_out,
                frames = count,
                "ingest finished"
            );
            break;
        }
    }
    let mut headers = HeaderMap::new();
    headers.insert(HDR_KIND, KIND_END);
    headers.insert(HDR_SENT, unix_ns().to_string().as_str());
    client
        .publish_with_headers(subject.clone(), headers, Vec::new().into())
        .await
        .map_err(publish_err)?;
    client.flush().await.map_err(|e| ClusterError::Publish {
        subject: subject.clone(),
        source: e.into(),
    })?;
    // The server answers a refused publish before the flush's pong; its handler may
    // run a moment later.
    tokio::time::sleep(Duration::from_millis(100)).await;
    if let Some(said) = refused.first() {
        return Err(ClusterError::Refused { subject, said }.into());
    }
    Ok(IngestReport {
        frames: count,
        subject,
    })
}
