//! Joining the DDS domain the way a ROS 2 node does, from the usual environment variables.
//!
//! - `ROS_DOMAIN_ID` (0–232, default 0): the domain, hence the UDP ports (7400 + 250 × id…).
//! - `ROS_LOCALHOST_ONLY=1` (Humble, Iron) or `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (Jazzy
//!   on): discovery and data only with processes on this machine, through the loopback
//!   interface: the participant advertises only 127.0.0.1, sends no multicast on any other
//!   interface, and finds its peers by unicast to the well-known discovery ports of 127.0.0.1.
//!   RustDDS still *binds* its receiving sockets to every interface (its sockets are not
//!   restricted by address), so a packet sent to this machine's other addresses on those ports
//!   reaches it; nothing is sent anywhere but loopback.
//! - `ROS_AUTOMATIC_DISCOVERY_RANGE=OFF`: refused (a node that discovers nothing maps nothing);
//!   `SUBNET` or `SYSTEM_DEFAULT`: every interface, as RustDDS does by default.
//! - `ROS_STATIC_PEERS`: not supported; set, it is named in a warning.

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::Context;
use ros2_client::dds::rustdds::DomainParticipantBuilder;

/// Why the DDS settings or the participant could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DdsError {
    /// An environment variable holds a value the node cannot use.
    #[error("{name}={value:?}: {why}")]
    Env {
        /// The variable.
        name: &'static str,
        /// Its value.
        value: String,
        /// What is wrong and what would do.
        why: &'static str,
    },
    /// RustDDS could not create the participant (a port in use, no interface, ...).
    #[error("cannot join DDS domain {domain_id}: {message}")]
    Participant {
        /// The domain.
        domain_id: u16,
        /// RustDDS's message.
        message: String,
    },
}

/// Which domain and which interfaces the node uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DdsSettings {
    /// The DDS domain (`ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// Loopback only (`ROS_LOCALHOST_ONLY=1` or `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`).
    pub localhost_only: bool,
}

/// The highest domain id whose ports fit the RTPS port mapping with ROS 2's participant counts.
pub const MAX_DOMAIN_ID: u16 = 232;

impl DdsSettings {
    /// The settings from the process's environment; the warnings to print beside them.
    pub fn from_env() -> Result<(DdsSettings, Vec<String>), DdsError> {
        Self::from_vars(|name| std::env::var(name).ok())
    }

    /// The settings from `var` (the environment, or a test's map).
    pub fn from_vars(
        var: impl Fn(&str) -> Option<String>,
    ) -> Result<(DdsSettings, Vec<String>), DdsError> {
        let mut warnings = Vec::new();
        let domain_id = match var("ROS_DOMAIN_ID").filter(|v| !v.trim().is_empty()) {
            None => 0,
            Some(v) => match v.trim().parse::<u16>() {
                Ok(id) if id <= MAX_DOMAIN_ID => id,
                _ => {
                    return Err(DdsError::Env {
                        name: "ROS_DOMAIN_ID",
                        value: v,
                        why: "a domain id is a whole number from 0 to 232",
                    });
                }
            },
        };
        let range = var("ROS_AUTOMATIC_DISCOVERY_RANGE").filter(|v| !v.trim().is_empty());
        let localhost_only = match range.as_deref().map(str::trim) {
            Some("LOCALHOST") => true,
            Some("SUBNET") | Some("SYSTEM_DEFAULT") | None => {
                var("ROS_LOCALHOST_ONLY").is_some_and(|v| v.trim() == "1")
            }
            Some("OFF") => {
                return Err(DdsError::Env {
                    name: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                    value: "OFF".into(),
                    why: "with discovery off the node would find no scans: use LOCALHOST to keep \
                          to this machine",
                });
            }
            Some(other) => {
                return Err(DdsError::Env {
                    name: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                    value: other.to_owned(),
                    why: "known values are LOCALHOST, SUBNET, SYSTEM_DEFAULT and OFF",
                });
            }
        };
        if let Some(peers) = var("ROS_STATIC_PEERS").filter(|v| !v.trim().is_empty()) {
            warnings.push(format!(
                "ROS_STATIC_PEERS={peers:?} is not supported and is ignored: peers are found by \
                 discovery"
            ));
        }
        Ok((
            DdsSettings {
                domain_id,
                localhost_only,
            },
            warnings,
        ))
    }

    /// A ROS 2 context (one DDS participant) with these settings.
    pub fn context(&self) -> Result<Context, DdsError> {
        let mut builder = DomainParticipantBuilder::new(self.domain_id);
        if self.localhost_only {
            builder = builder
                .with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)])
                .same_host_loopback(true);
        }
        let fail = |message: String| DdsError::Participant {
            domain_id: self.domain_id,
            message,
        };
        let participant = builder.build().map_err(|e| fail(e.to_string()))?;
        Context::from_domain_participant(participant).map_err(|e| fail(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn settings(vars: &[(&str, &str)]) -> Result<(DdsSettings, Vec<String>), DdsError> {
        let map: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .collect();
        DdsSettings::from_vars(|k| map.get(k).cloned())
    }

    #[test]
    fn no_variables_mean_domain_zero_on_every_interface() {
        let (s, w) = settings(&[]).unwrap();
        assert_eq!(
            s,
            DdsSettings {
                domain_id: 0,
                localhost_only: false
            }
        );
        assert!(w.is_empty());
    }

    #[test]
    fn either_localhost_setting_keeps_to_loopback() {
        assert!(
            settings(&[("ROS_LOCALHOST_ONLY", "1")])
                .unwrap()
                .0
                .localhost_only
        );
        let jazzy = settings(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")]).unwrap();
        assert!(jazzy.0.localhost_only);
        assert!(
            !settings(&[("ROS_LOCALHOST_ONLY", "0")])
                .unwrap()
                .0
                .localhost_only
        );
    }

    #[test]
    fn a_bad_domain_or_range_is_refused_by_name() {
        for (k, v) in [
            ("ROS_DOMAIN_ID", "233"),
            ("ROS_DOMAIN_ID", "x"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LAN"),
        ] {
            let e = settings(&[(k, v)]).unwrap_err().to_string();
            assert!(e.starts_with(k), "{e}");
        }
        assert_eq!(
            settings(&[("ROS_DOMAIN_ID", "42")]).unwrap().0.domain_id,
            42
        );
    }

    #[test]
    fn static_peers_are_named_in_a_warning() {
        let (_, w) = settings(&[("ROS_STATIC_PEERS", "10.0.0.2")]).unwrap();
        assert!(w[0].contains("ROS_STATIC_PEERS"), "{w:?}");
    }
}
