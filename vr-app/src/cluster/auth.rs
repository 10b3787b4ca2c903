//! Who may do what in a session: one NATS user per role, each held to its subjects by
//! the server.
//!
//! A role connects with its own [`Credentials`] (a user and password, or an nkey seed
//! file): the ingest's, each owner's, the render nodes'. The server's `authorization`
//! block ([`server_authorization`], shown in `docs/cluster.md` and run by
//! `tests/tests/cluster.rs`) lets
//! - the **ingest** publish tracking frames (`<session>.tracking.*`) and nothing else;
//! - an **owner** publish operations and its end marker on its own subject
//!   (`<session>.ops.<owner>`) and its wand (`<session>.wand.<owner>`), create the
//!   stream and the snapshot bucket and write snapshots;
//! - a **render node** read the stream, the snapshots and the feeds, and publish its
//!   frame barrier reports, nothing that changes the document.
//!
//! The nodes check what the server cannot: an operation's owner is the last token of
//! its subject, and an owner the config does not name is refused (see
//! [`super::node`]).
//!
//! ```
//! use vr_app::cluster::auth::{Principal, RoleUsers, server_authorization};
//! let users = RoleUsers {
//!     ingest: vec![Principal::Password { user: "ingest".into(), password: "p1".into() }],
//!     owners: vec![("front".into(), Principal::Nkey("UABC".into()))],
//!     render: vec![],
//! };
//! let block = server_authorization("cave1", &users);
//! assert!(block.contains(r#"publish: { allow: ["cave1.tracking.*"] }"#));
//! assert!(block.contains(r#""cave1.ops.front""#));
//! ```

use std::time::Duration;

use super::{ClusterConfigError, ClusterError};

pub use crate::config::cluster::Credentials;

impl Credentials {
    /// The client's options for these credentials (the nkey seed read from its file).
    pub fn connect_options(&self) -> Result<async_nats::ConnectOptions, ClusterError> {
        let opts = match (&self.user, &self.password, &self.nkey) {
            (Some(u), Some(p), _) => {
                async_nats::ConnectOptions::with_user_and_password(u.clone(), p.clone())
            }
            (_, _, Some(path)) => {
                let seed = std::fs::read_to_string(path).map_err(|source| {
                    ClusterError::Config(ClusterConfigError::NkeyFile {
                        path: path.clone(),
                        source,
                    })
                })?;
                async_nats::ConnectOptions::with_nkey(seed.trim().to_string())
            }
            _ => async_nats::ConnectOptions::new(),
        };
        Ok(opts.connection_timeout(Duration::from_secs(5)))
    }
}

/// How the server knows one user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Principal {
    /// A user name and password.
    Password {
        /// The user name.
        user: String,
        /// The password.
        password: String,
    },
    /// An nkey user: its public key (`U...`).
    Nkey(String),
}

/// The users of each role of one session.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RoleUsers {
    /// Ingest users (they publish tracking frames on any feed of the session).
    pub ingest: Vec<Principal>,
    /// Each owner node's name and its user (one user per owner: the subject it may
    /// publish operations on names it).
    pub owners: Vec<(String, Principal)>,
    /// Render node users (they read; they change no document).
    pub render: Vec<Principal>,
}

/// What a render node reads and publishes (every node, owners too): the stream, the
/// snapshot bucket, the feeds, the barrier and the wands.
fn reader(session: &str) -> (Vec<String>, Vec<String>) {
    let stream = format!("WS_{session}");
    let bucket = format!("OBJ_WS_{session}_snap");
    let mut publish = vec![format!("{session}.barrier"), "$JS.API.INFO".to_string()];
    for s in [&stream, &bucket] {
        publish.extend([
            format!("$JS.API.STREAM.INFO.{s}"),
            format!("$JS.API.STREAM.MSG.GET.{s}"),
            format!("$JS.API.DIRECT.GET.{s}"),
            format!("$JS.API.DIRECT.GET.{s}.>"),
            format!("$JS.API.CONSUMER.CREATE.{s}"),
            format!("$JS.API.CONSUMER.CREATE.{s}.>"),
            format!("$JS.API.CONSUMER.MSG.NEXT.{s}.>"),
            format!("$JS.API.CONSUMER.INFO.{s}.>"),
            format!("$JS.API.CONSUMER.DELETE.{s}.>"),
            format!("$JS.FC.{s}.>"),
        ]);
    }
    let subscribe = vec![
        "_INBOX.>".to_string(),
        format!("{session}.tracking.*"),
        format!("{session}.barrier"),
        format!("{session}.wand.*"),
    ];
    (publish, subscribe)
}

fn quoted(list: &[String]) -> String {
    let items: Vec<String> = list.iter().map(|s| format!("\"{s}\"")).collect();
    format!("[{}]", items.join(", "))
}

fn user_line(p: &Principal, publish: &[String], subscribe: &[String]) -> String {
    let who = match p {
        Principal::Password { user, password } => {
            format!("user: \"{user}\", password: \"{password}\"")
        }
        Principal::Nkey(public) => format!("nkey: \"{public}\""),
    };
    format!(
        "    {{ {who}, permissions: {{\n        publish: {{ allow: {} }}\n        subscribe: {{ allow: {} }}\n    }} }}\n",
        quoted(publish),
        quoted(subscribe)
    )
}

/// The server's `authorization` block for `session`: each user held to its role's
/// subjects (see the module docs). Put it in the server's config beside `listen` and
/// `jetstream`.
pub fn server_authorization(session: &str, users: &RoleUsers) -> String {
    let (read_pub, read_sub) = reader(session);
    let mut out = String::from("authorization {\n  users = [\n");
    for p in &users.ingest {
        out.push_str(&user_line(
            p,
            &[format!("{session}.tracking.*")],
            &["_INBOX.>".to_string()],
        ));
    }
    for (owner, p) in &users.owners {
        let mut publish = read_pub.clone();
        publish.extend([
            format!("{session}.ops.{owner}"),
            format!("{session}.wand.{owner}"),
            format!("$JS.API.STREAM.CREATE.WS_{session}"),
            format!("$JS.API.STREAM.CREATE.OBJ_WS_{session}_snap"),
            format!("$JS.API.STREAM.PURGE.OBJ_WS_{session}_snap"),
            format!("$O.WS_{session}_snap.>"),
        ]);
        out.push_str(&user_line(p, &publish, &read_sub));
    }
    for p in &users.render {
        out.push_str(&user_line(p, &read_pub, &read_sub));
    }
    out.push_str("  ]\n}\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The users of `docs/cluster.md`'s example: the ingest's and `front`'s nkeys, the
    /// render nodes' password.
    fn docs_example() -> RoleUsers {
        RoleUsers {
            ingest: vec![Principal::Nkey(DOCS_INGEST_KEY.into())],
            owners: vec![("front".into(), Principal::Nkey(DOCS_FRONT_KEY.into()))],
            render: vec![Principal::Password {
                user: "render".into(),
                password: "change-me".into(),
            }],
        }
    }

    const DOCS_INGEST_KEY: &str = "UACVOKIRXT3H5NNOAVE3CG3KUPGJFBMVRKBF2JTE6RD5LITWF25LQL6Y";
    const DOCS_FRONT_KEY: &str = "UDF5I7U4MXQORBSIL33GBHHHOTVVW3UMHSWFWQTABTX5JIURCKXP5MQ2";

    /// The server config `docs/cluster.md` shows is this module's, for its example.
    #[test]
    fn the_docs_show_the_server_authorization_of_their_example() {
        let docs = include_str!("../../../docs/cluster.md");
        let block = server_authorization("cave1", &docs_example());
        assert!(
            docs.contains(&block),
            "docs/cluster.md must show, after its jetstream line:\n{block}"
        );
    }

    #[test]
    fn credentials_are_taken_whole_and_checked() {
        let pw = Credentials {
            user: Some("u".into()),
            password: Some("p".into()),
            nkey: None,
        };
        let nk = Credentials {
            nkey: Some("/k".into()),
            ..Credentials::default()
        };
        assert_eq!(Credentials::default().or(pw.clone()), pw);
        assert_eq!(nk.clone().or(pw.clone()), nk);
        assert!(pw.validate("x").is_ok() && nk.validate("x").is_ok());
        let half = Credentials {
            password: None,
            ..pw.clone()
        };
        assert!(matches!(
            half.validate("[cluster.ingest]"),
            Err(ClusterConfigError::Credentials(w)) if w == "[cluster.ingest]"
        ));
        let both = Credentials {
            nkey: Some("/k".into()),
            ..pw
        };
        assert!(matches!(
            both.validate("x"),
            Err(ClusterConfigError::NkeyAndUser(_))
        ));
    }

    #[test]
    fn a_missing_nkey_file_is_named() {
        let c = Credentials {
            nkey: Some("/nonexistent/front.nk".into()),
            ..Credentials::default()
        };
        let e = c.connect_options().unwrap_err();
        assert!(
            sculpt_core::error::Chain(&e)
                .to_string()
                .contains("/nonexistent/front.nk"),
            "{e}"
        );
    }

    /// Only an owner may publish operations (on its own subject), only the ingest
    /// tracking frames; a render node neither.
    #[test]
    fn each_role_publishes_only_its_own_subjects() {
        let users = RoleUsers {
            ingest: vec![Principal::Nkey("UINGEST".into())],
            owners: vec![
                ("front".into(), Principal::Nkey("UFRONT".into())),
                ("desk".into(), Principal::Nkey("UDESK".into())),
            ],
            render: vec![Principal::Password {
                user: "render".into(),
                password: "pw".into(),
            }],
        };
        let block = server_authorization("s1", &users);
        let line = |who: &str| {
            let at = block.find(who).unwrap();
            let end = block[at..].find("} }").unwrap();
            block[at..at + end].to_string()
        };
        let (ingest, front, desk, render) = (
            line("UINGEST"),
            line("UFRONT"),
            line("UDESK"),
            line("\"render\""),
        );
        let publishes = |who: &str, subject: &str| {
            let p = who.split("subscribe").next().unwrap();
            p.contains(&format!("\"{subject}\""))
        };
        assert!(publishes(&ingest, "s1.tracking.*"));
        assert!(!publishes(&ingest, "s1.ops.front"));
        assert!(publishes(&front, "s1.ops.front") && !publishes(&front, "s1.ops.desk"));
        assert!(publishes(&desk, "s1.ops.desk") && !publishes(&desk, "s1.ops.front"));
        for who in [&front, &desk, &render] {
            assert!(!publishes(who, "s1.tracking.*"));
        }
        assert!(!render.contains("s1.ops.") && !render.contains("$O."));
        assert!(!render.contains("STREAM.CREATE") && !render.contains("s1.wand.front\""));
    }
}
