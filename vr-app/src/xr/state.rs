//! The OpenXR session lifecycle as a pure state machine: session state changes (and
//! the app's own quit request) in, what the app must do out. The runtime glue
//! (`xr_runtime`, feature `openxr`) feeds it every `XrEventDataSessionStateChanged` and
//! `XrEventDataInstanceLossPending` it polls and does what it answers; tests drive it
//! with recorded event sequences, no runtime needed.
//!
//! The rules are those of the OpenXR 1.0 specification, section 9.3 ("Session
//! lifecycle"):
//! * `READY`: call `xrBeginSession`; from then on the frame loop runs
//!   (`xrWaitFrame` / `xrBeginFrame` / `xrEndFrame`) in `SYNCHRONIZED`, `VISIBLE` and
//!   `FOCUSED`;
//! * layers are rendered and submitted only while `VISIBLE` or `FOCUSED` and the frame
//!   state says `shouldRender`; in `SYNCHRONIZED` frames are ended with no layers;
//! * controller input is read only while `FOCUSED` (actions are inactive otherwise);
//! * `STOPPING`: call `xrEndSession`;
//! * `LOSS_PENDING` (the session is lost, e.g. the headset was unplugged): end the
//!   session if it is running, then exit; `EXITING`: exit. An instance loss pending
//!   event is handled the same way as session loss;
//! * the app's own quit (a frame limit, Ctrl-C) while the session runs calls
//!   `xrRequestExitSession`, after which the runtime walks the session through
//!   `STOPPING`, `IDLE` and `EXITING`; with no session running it exits at once.
//!
//! ```
//! use vr_app::xr::state::{Lifecycle, LifecycleEvent, SessionAction, SessionState};
//! let mut life = Lifecycle::default();
//! assert_eq!(life.handle(LifecycleEvent::State(SessionState::Ready)), vec![SessionAction::BeginSession]);
//! life.handle(LifecycleEvent::State(SessionState::Synchronized));
//! life.handle(LifecycleEvent::State(SessionState::Visible));
//! life.handle(LifecycleEvent::State(SessionState::Focused));
//! let f = life.frame(true);
//! assert!(f.wait && f.render && f.read_input);
//! ```

/// The OpenXR session states (`XrSessionState`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SessionState {
    /// No state change seen yet (`XR_SESSION_STATE_UNKNOWN`).
    Unknown,
    /// Created, not ready to begin.
    Idle,
    /// Ready: the app should begin the session.
    Ready,
    /// Frames are synchronised with the runtime; nothing is shown.
    Synchronized,
    /// Shown to the user but without input focus.
    Visible,
    /// Shown, with input focus.
    Focused,
    /// The app should end the session.
    Stopping,
    /// The session is lost; the app should end it and exit (or retry later).
    LossPending,
    /// The runtime wants the app to exit.
    Exiting,
}

/// What the app tells the state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LifecycleEvent {
    /// `XrEventDataSessionStateChanged` with the new state.
    State(SessionState),
    /// `XrEventDataInstanceLossPending`: the runtime is going away.
    InstanceLossPending,
    /// The app wants to stop (frame limit reached, Ctrl-C).
    QuitRequested,
}

/// Why the app leaves the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitReason {
    /// The runtime asked (`EXITING`), after the app's own request or the user's.
    Requested,
    /// The session or the instance was lost (headset unplugged, runtime gone).
    Lost,
}

/// What the app must do in answer to an event, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionAction {
    /// Call `xrBeginSession` (with the stereo view configuration).
    BeginSession,
    /// Call `xrEndSession`.
    EndSession,
    /// Call `xrRequestExitSession`.
    RequestExit,
    /// Leave the frame loop and tear down.
    Exit(ExitReason),
}

/// What to do in one iteration of the frame loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FramePlan {
    /// Run `xrWaitFrame` / `xrBeginFrame` / `xrEndFrame` (the session is running).
    pub wait: bool,
    /// Render both eyes and submit the projection layer (otherwise end the frame with
    /// no layers).
    pub render: bool,
    /// Sync the actions and read the controllers.
    pub read_input: bool,
}

/// The session lifecycle (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lifecycle {
    state: SessionState,
    running: bool,
    exit_requested: bool,
    exited: Option<ExitReason>,
}

impl Default for Lifecycle {
    fn default() -> Self {
        Self {
            state: SessionState::Unknown,
            running: false,
            exit_requested: false,
            exited: None,
        }
    }
}

impl Lifecycle {
    /// The last state the runtime reported.
    pub fn state(&self) -> SessionState {
        self.state
    }

    /// Whether the session has begun and not ended.
    pub fn running(&self) -> bool {
        self.running
    }

    /// Why the app left, once it has.
    pub fn exited(&self) -> Option<ExitReason> {
        self.exited
    }

    /// Handles one event and returns what to do, in order. After an exit every event
    /// is answered with nothing.
    pub fn handle(&mut self, event: LifecycleEvent) -> Vec<SessionAction> {
        if self.exited.is_some() {
            return Vec::new();
        }
        let mut actions = Vec::new();
        match event {
            LifecycleEvent::State(state) => {
                self.state = state;
                match state {
                    SessionState::Ready if !self.running => {
                        if self.exit_requested {
                            // Asked to quit before the session ever ran.
                            self.exit(ExitReason::Requested, &mut actions);
                        } else {
                            self.running = true;
                            actions.push(SessionAction::BeginSession);
                        }
                    }
                    SessionState::Stopping if self.running => {
                        self.running = false;
                        actions.push(SessionAction::EndSession);
                    }
                    SessionState::LossPending => self.lose(&mut actions),
                    SessionState::Exiting => {
                        if self.running {
                            self.running = false;
                            actions.push(SessionAction::EndSession);
                        }
                        self.exit(ExitReason::Requested, &mut actions);
                    }
                    SessionState::Idle if self.exit_requested && !self.running => {
                        // The runtime may stay idle after STOPPING; the app leaves.
                        self.exit(ExitReason::Requested, &mut actions);
                    }
                    _ => {}
                }
            }
            LifecycleEvent::InstanceLossPending => self.lose(&mut actions),
            LifecycleEvent::QuitRequested => {
                if self.running {
                    if !self.exit_requested {
                        actions.push(SessionAction::RequestExit);
                    }
                } else {
                    self.exit(ExitReason::Requested, &mut actions);
                }
                self.exit_requested = true;
            }
        }
        actions
    }

    fn lose(&mut self, actions: &mut Vec<SessionAction>) {
        if self.running {
            self.running = false;
            actions.push(SessionAction::EndSession);
        }
        self.exit(ExitReason::Lost, actions);
    }

    fn exit(&mut self, reason: ExitReason, actions: &mut Vec<SessionAction>) {
        self.exited = Some(reason);
        actions.push(SessionAction::Exit(reason));
    }

    /// What this frame does; `should_render` is the frame state's `shouldRender` (pass
    /// `true` before `xrWaitFrame` has answered to ask whether to wait at all).
    pub fn frame(&self, should_render: bool) -> FramePlan {
        let in_frame_loop = self.running
            && matches!(
                self.state,
                SessionState::Ready
                    | SessionState::Synchronized
                    | SessionState::Visible
                    | SessionState::Focused
            );
        let shown = matches!(self.state, SessionState::Visible | SessionState::Focused);
        FramePlan {
            wait: in_frame_loop,
            render: in_frame_loop && shown && should_render,
            read_input: in_frame_loop && self.state == SessionState::Focused,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use LifecycleEvent::{InstanceLossPending, QuitRequested, State};
    use SessionAction::{BeginSession, EndSession, Exit, RequestExit};
    use SessionState::*;

    /// Runs a recorded sequence and returns every action, in order.
    fn run(life: &mut Lifecycle, events: &[LifecycleEvent]) -> Vec<SessionAction> {
        events.iter().flat_map(|&e| life.handle(e)).collect()
    }

    #[test]
    fn a_normal_session_begins_renders_when_shown_and_ends_on_request() {
        let mut life = Lifecycle::default();
        assert_eq!(
            life.frame(true),
            FramePlan::default(),
            "nothing before READY"
        );
        assert_eq!(run(&mut life, &[State(Idle), State(Ready)]), [BeginSession]);
        assert!(life.frame(true).wait && !life.frame(true).render);
        run(&mut life, &[State(Synchronized)]);
        let sync = life.frame(true);
        assert!(sync.wait && !sync.render && !sync.read_input);
        run(&mut life, &[State(Visible)]);
        let visible = life.frame(true);
        assert!(visible.render && !visible.read_input, "{visible:?}");
        assert!(!life.frame(false).render, "shouldRender false: no layers");
        run(&mut life, &[State(Focused)]);
        assert_eq!(
            life.frame(true),
            FramePlan {
                wait: true,
                render: true,
                read_input: true
            }
        );
        // The user quits: ask the runtime, which stops, idles and exits.
        assert_eq!(run(&mut life, &[QuitRequested]), [RequestExit]);
        assert!(life.frame(true).wait, "frames go on until STOPPING");
        assert_eq!(run(&mut life, &[QuitRequested]), [], "asked once");
        let tail = run(
            &mut life,
            &[State(Visible), State(Synchronized), State(Stopping)],
        );
        assert_eq!(tail, [EndSession]);
        assert!(!life.frame(true).wait, "no frames after xrEndSession");
        assert_eq!(
            run(&mut life, &[State(Idle), State(Exiting)]),
            [Exit(ExitReason::Requested)]
        );
        assert_eq!(life.exited(), Some(ExitReason::Requested));
        assert_eq!(run(&mut life, &[State(Ready)]), [], "nothing after exit");
    }

    #[test]
    fn loss_pending_while_focused_ends_the_session_and_exits_as_lost() {
        let mut life = Lifecycle::default();
        let actions = run(
            &mut life,
            &[
                State(Idle),
                State(Ready),
                State(Synchronized),
                State(Visible),
                State(Focused),
                State(LossPending),
            ],
        );
        assert_eq!(actions, [BeginSession, EndSession, Exit(ExitReason::Lost)]);
        assert!(!life.running());
        assert_eq!(life.frame(true), FramePlan::default());
    }

    #[test]
    fn loss_pending_before_the_session_began_exits_without_ending_it() {
        let mut life = Lifecycle::default();
        let actions = run(&mut life, &[State(Idle), State(LossPending)]);
        assert_eq!(actions, [Exit(ExitReason::Lost)]);
    }

    #[test]
    fn instance_loss_is_handled_like_session_loss() {
        let mut life = Lifecycle::default();
        let actions = run(
            &mut life,
            &[State(Ready), State(Synchronized), InstanceLossPending],
        );
        assert_eq!(actions, [BeginSession, EndSession, Exit(ExitReason::Lost)]);
    }

    #[test]
    fn runtime_stopping_without_a_request_ends_and_can_begin_again() {
        // The runtime stops the session (e.g. another app took the headset) and later
        // makes it ready again: the app ends it, then begins it anew.
        let mut life = Lifecycle::default();
        let actions = run(
            &mut life,
            &[
                State(Ready),
                State(Synchronized),
                State(Visible),
                State(Stopping),
                State(Idle),
                State(Ready),
            ],
        );
        assert_eq!(actions, [BeginSession, EndSession, BeginSession]);
        assert!(life.running());
        assert_eq!(life.exited(), None);
    }

    #[test]
    fn exiting_while_running_ends_the_session_first() {
        let mut life = Lifecycle::default();
        let actions = run(&mut life, &[State(Ready), State(Focused), State(Exiting)]);
        assert_eq!(
            actions,
            [BeginSession, EndSession, Exit(ExitReason::Requested)]
        );
    }

    #[test]
    fn quit_before_the_session_runs_exits_at_once() {
        let mut life = Lifecycle::default();
        assert_eq!(
            run(&mut life, &[State(Idle), QuitRequested]),
            [Exit(ExitReason::Requested)]
        );
        // A quit after STOPPING, with the runtime idling, also exits at once.
        let mut life = Lifecycle::default();
        let actions = run(
            &mut life,
            &[State(Ready), State(Stopping), QuitRequested, State(Idle)],
        );
        assert_eq!(
            actions,
            [BeginSession, EndSession, Exit(ExitReason::Requested)]
        );
    }

    #[test]
    fn stopping_requested_then_idle_exits_even_without_exiting_state() {
        let mut life = Lifecycle::default();
        let actions = run(
            &mut life,
            &[
                State(Ready),
                State(Focused),
                QuitRequested,
                State(Stopping),
                State(Idle),
            ],
        );
        assert_eq!(
            actions,
            [
                BeginSession,
                RequestExit,
                EndSession,
                Exit(ExitReason::Requested)
            ]
        );
    }
}
