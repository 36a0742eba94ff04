//! Typed key expressions: the only place in wearnav where key strings are formatted.
//!
//! Key space (ARCHITECTURE.md), one user per prefix so several people can share a LAN:
//! `wearnav/<user>/sensor/<device>/{depth,imu,odom,pressure,truth}`, `perception/{scan,hazard}`,
//! `localization/{pose,camera}`, `route/state`, `feedback/{haptic,speech,applied}`, `cmd/<verb>`,
//! `health/<agent>`, `query/<service>`, `phone/{haptic,speech,ack}` (the phone app as a feedback
//! device, through the phone bridge; `sensor/phone/motion` is the phone's compass and steps).

use thiserror::Error;

/// Why a user, device, agent or verb name cannot be used as a key chunk.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum KeyError {
    /// Empty names would produce `wearnav//...`, which Zenoh rejects.
    #[error("{what} name is empty")]
    Empty {
        /// Which name (user, device, agent, verb, service).
        what: &'static str,
    },
    /// Zenoh reserves `/ * $ ? #` and whitespace would make keys unreadable in logs.
    #[error("{what} name {name:?} contains {bad:?}; use letters, digits, '-', '_' or '.'")]
    BadChar {
        /// Which name.
        what: &'static str,
        /// The name given.
        name: String,
        /// The first offending character.
        bad: char,
    },
}

/// Check that `name` can stand as one chunk of a key expression.
pub fn check_chunk(what: &'static str, name: &str) -> Result<(), KeyError> {
    if name.is_empty() {
        return Err(KeyError::Empty { what });
    }
    if let Some(bad) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))) {
        return Err(KeyError::BadChar { what, name: name.to_string(), bad });
    }
    Ok(())
}

/// Key builder for one user's prefix `wearnav/<user>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    prefix: String,
}

impl Keys {
    /// Keys for `user`; fails when the name cannot be a key chunk.
    pub fn new(user: &str) -> Result<Self, KeyError> {
        check_chunk("user", user)?;
        Ok(Self { prefix: format!("wearnav/{user}") })
    }

    /// The user's prefix, `wearnav/<user>`.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    /// Everything of this user: `wearnav/<user>/**`.
    pub fn all(&self) -> String {
        format!("{}/**", self.prefix)
    }

    fn sensor(&self, device: &str, stream: &str) -> String {
        format!("{}/sensor/{device}/{stream}", self.prefix)
    }

    /// Compressed depth frames of one device.
    pub fn depth(&self, device: &str) -> String {
        self.sensor(device, "depth")
    }

    /// Depth frames of every device (`sensor/*/depth`).
    pub fn depth_any(&self) -> String {
        self.sensor("*", "depth")
    }

    /// IMU sample batches of one device.
    pub fn imu(&self, device: &str) -> String {
        self.sensor(device, "imu")
    }

    /// IMU batches of every device.
    pub fn imu_any(&self) -> String {
        self.sensor("*", "imu")
    }

    /// Odometry increments of one device.
    pub fn odom(&self, device: &str) -> String {
        self.sensor(device, "odom")
    }

    /// Odometry increments of every device.
    pub fn odom_any(&self) -> String {
        self.sensor("*", "odom")
    }

    /// Ground-truth pose (simulator only).
    pub fn truth(&self, device: &str) -> String {
        self.sensor(device, "truth")
    }

    /// Ground truth of every device.
    pub fn truth_any(&self) -> String {
        self.sensor("*", "truth")
    }

    /// Nearest-point scan in the user frame.
    pub fn scan(&self) -> String {
        format!("{}/perception/scan", self.prefix)
    }

    /// Costs, rumble state, ground plane, latency breakdown.
    pub fn hazard(&self) -> String {
        format!("{}/perception/hazard", self.prefix)
    }

    /// Pose on the floor map.
    pub fn pose(&self) -> String {
        format!("{}/localization/pose", self.prefix)
    }

    /// Where the scan's frame is on the map, each frame (`localization/camera`).
    pub fn camera_place(&self) -> String {
        format!("{}/localization/camera", self.prefix)
    }

    /// Current route and next waypoint.
    pub fn route_state(&self) -> String {
        format!("{}/route/state", self.prefix)
    }

    /// Device-neutral haptic intents.
    pub fn haptic(&self) -> String {
        format!("{}/feedback/haptic", self.prefix)
    }

    /// Speech intents.
    pub fn speech(&self) -> String {
        format!("{}/feedback/speech", self.prefix)
    }

    /// What a device actually did.
    pub fn applied(&self) -> String {
        format!("{}/feedback/applied", self.prefix)
    }

    /// What the phone page should vibrate (the feedback agent's phone backend to the
    /// phone bridge).
    pub fn phone_haptic(&self) -> String {
        format!("{}/phone/haptic", self.prefix)
    }

    /// What the phone page should say or stop saying.
    pub fn phone_speech(&self) -> String {
        format!("{}/phone/speech", self.prefix)
    }

    /// What the phone page did with each request (the bridge to the feedback agent).
    pub fn phone_ack(&self) -> String {
        format!("{}/phone/ack", self.prefix)
    }

    /// The phone's compass heading and steps (`sensor/<device>/motion`).
    pub fn motion(&self, device: &str) -> String {
        self.sensor(device, "motion")
    }

    /// Barometer readings of one device (`sensor/<device>/pressure`).
    pub fn pressure(&self, device: &str) -> String {
        self.sensor(device, "pressure")
    }

    /// Barometer readings of every device.
    pub fn pressure_any(&self) -> String {
        self.sensor("*", "pressure")
    }

    /// One user command verb (`destination`, `where-am-i`, `mute`, `repeat`, `cancel`,
    /// `floor`).
    pub fn cmd(&self, verb: &str) -> String {
        format!("{}/cmd/{verb}", self.prefix)
    }

    /// Every user command.
    pub fn cmd_any(&self) -> String {
        format!("{}/cmd/*", self.prefix)
    }

    /// Liveliness token and periodic stats of one agent.
    pub fn health(&self, agent: &str) -> String {
        format!("{}/health/{agent}", self.prefix)
    }

    /// Health of every agent.
    pub fn health_any(&self) -> String {
        format!("{}/health/*", self.prefix)
    }

    /// A queryable service (route planning, map, destinations).
    pub fn query(&self, service: &str) -> String {
        format!("{}/query/{service}", self.prefix)
    }

    /// The device chunk of a `sensor/<device>/...` key of this user, if it is one.
    pub fn device_of<'k>(&self, key: &'k str) -> Option<&'k str> {
        let rest = key.strip_prefix(self.prefix.as_str())?.strip_prefix("/sensor/")?;
        rest.split('/').next()
    }

    /// The agent chunk of a `health/<agent>` key of this user, if it is one.
    pub fn agent_of<'k>(&self, key: &'k str) -> Option<&'k str> {
        key.strip_prefix(self.prefix.as_str())?.strip_prefix("/health/")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_follow_the_architecture_key_space() {
        let k = Keys::new("alice").unwrap();
        assert_eq!(k.depth("cane"), "wearnav/alice/sensor/cane/depth");
        assert_eq!(k.depth_any(), "wearnav/alice/sensor/*/depth");
        assert_eq!(k.hazard(), "wearnav/alice/perception/hazard");
        assert_eq!(k.applied(), "wearnav/alice/feedback/applied");
        assert_eq!(k.cmd("where-am-i"), "wearnav/alice/cmd/where-am-i");
        assert_eq!(k.health("compute-agent"), "wearnav/alice/health/compute-agent");
        assert_eq!(k.all(), "wearnav/alice/**");
        assert_eq!(k.phone_haptic(), "wearnav/alice/phone/haptic");
        assert_eq!(k.phone_speech(), "wearnav/alice/phone/speech");
        assert_eq!(k.phone_ack(), "wearnav/alice/phone/ack");
        assert_eq!(k.motion("phone"), "wearnav/alice/sensor/phone/motion");
    }

    #[test]
    fn bad_user_names_are_refused_with_the_offending_char() {
        assert_eq!(Keys::new(""), Err(KeyError::Empty { what: "user" }));
        let err = Keys::new("al/ice").unwrap_err();
        assert!(err.to_string().contains("'/'"), "{err}");
        assert!(Keys::new("a*").is_err());
        assert!(Keys::new("bob-2.test_x").is_ok());
    }

    #[test]
    fn device_and_agent_are_recovered_from_keys() {
        let k = Keys::new("bob").unwrap();
        assert_eq!(k.device_of("wearnav/bob/sensor/cane/depth"), Some("cane"));
        assert_eq!(k.device_of("wearnav/eve/sensor/cane/depth"), None);
        assert_eq!(k.agent_of("wearnav/bob/health/feedback-agent"), Some("feedback-agent"));
    }
}
