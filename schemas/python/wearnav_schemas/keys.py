"""Typed key expressions, mirroring ``schemas/src/keys.rs`` (the golden file
``schemas/vectors/keys.json`` holds the Rust output these must equal).

Key space, one user per prefix: ``wearnav/<user>/sensor/<device>/{depth,imu,odom,pressure,truth}``,
``perception/{scan,hazard}``, ``localization/{pose,camera}``, ``route/state``,
``feedback/{haptic,speech,applied}``, ``cmd/<verb>``, ``health/<agent>``, ``query/<service>``,
``phone/{haptic,speech,ack}`` (the phone as a feedback device, through the phone bridge)
``sensor/phone/motion`` (the phone's compass and steps) and ``sensor/<device>/pressure``
(a barometer's readings).
"""


class KeyNameError(ValueError):
    """A user, device, agent or verb name that cannot be one chunk of a key expression."""


def check_chunk(what, name):
    """Refuse names Zenoh would reject or that would read badly in logs: empty names,
    and anything but ASCII letters, digits, ``-``, ``_`` and ``.``."""
    if not name:
        raise KeyNameError(f"{what} name is empty")
    for ch in name:
        if not (ch.isascii() and ch.isalnum() or ch in "-_."):
            raise KeyNameError(
                f"{what} name {name!r} contains {ch!r}; use letters, digits, '-', '_' or '.'"
            )


class Keys:
    """Key builder for one user's prefix ``wearnav/<user>``."""

    def __init__(self, user):
        check_chunk("user", user)
        self._prefix = f"wearnav/{user}"

    def prefix(self):
        """The user's prefix, ``wearnav/<user>``."""
        return self._prefix

    def all(self):
        """Everything of this user: ``wearnav/<user>/**``."""
        return f"{self._prefix}/**"

    def _sensor(self, device, stream):
        return f"{self._prefix}/sensor/{device}/{stream}"

    def depth(self, device):
        """Compressed depth frames of one device."""
        return self._sensor(device, "depth")

    def depth_any(self):
        """Depth frames of every device."""
        return self._sensor("*", "depth")

    def imu(self, device):
        """IMU sample batches of one device."""
        return self._sensor(device, "imu")

    def imu_any(self):
        """IMU batches of every device."""
        return self._sensor("*", "imu")

    def odom(self, device):
        """Odometry increments of one device."""
        return self._sensor(device, "odom")

    def odom_any(self):
        """Odometry increments of every device."""
        return self._sensor("*", "odom")

    def truth(self, device):
        """Ground-truth pose (simulator only)."""
        return self._sensor(device, "truth")

    def truth_any(self):
        """Ground truth of every device."""
        return self._sensor("*", "truth")

    def scan(self):
        """Nearest-point scan in the user frame."""
        return f"{self._prefix}/perception/scan"

    def hazard(self):
        """Costs, rumble state, ground plane, latency breakdown."""
        return f"{self._prefix}/perception/hazard"

    def pose(self):
        """Pose on the floor map."""
        return f"{self._prefix}/localization/pose"

    def camera_place(self):
        """Where the scan's frame is on the map, each frame (``localization/camera``)."""
        return f"{self._prefix}/localization/camera"

    def route_state(self):
        """Current route and next waypoint."""
        return f"{self._prefix}/route/state"

    def haptic(self):
        """Device-neutral haptic intents."""
        return f"{self._prefix}/feedback/haptic"

    def speech(self):
        """Speech intents."""
        return f"{self._prefix}/feedback/speech"

    def applied(self):
        """What a device actually did."""
        return f"{self._prefix}/feedback/applied"

    def phone_haptic(self):
        """What the phone page should vibrate (feedback agent to phone bridge)."""
        return f"{self._prefix}/phone/haptic"

    def phone_speech(self):
        """What the phone page should say or stop saying."""
        return f"{self._prefix}/phone/speech"

    def phone_ack(self):
        """What the phone page did with each request (phone bridge to feedback agent)."""
        return f"{self._prefix}/phone/ack"

    def motion(self, device):
        """The phone's compass heading and steps (``sensor/<device>/motion``)."""
        return self._sensor(device, "motion")

    def pressure(self, device):
        """Barometer readings of one device (``sensor/<device>/pressure``)."""
        return self._sensor(device, "pressure")

    def pressure_any(self):
        """Barometer readings of every device."""
        return self._sensor("*", "pressure")

    def cmd(self, verb):
        """One user command verb (``destination``, ``where-am-i``, ``mute``, ``repeat``,
        ``cancel``, ``floor``, ``door``)."""
        return f"{self._prefix}/cmd/{verb}"

    def cmd_any(self):
        """Every user command."""
        return f"{self._prefix}/cmd/*"

    def health(self, agent):
        """Liveliness token and periodic stats of one agent."""
        return f"{self._prefix}/health/{agent}"

    def health_any(self):
        """Health of every agent."""
        return f"{self._prefix}/health/*"

    def query(self, service):
        """A queryable service (route planning, map, destinations)."""
        return f"{self._prefix}/query/{service}"

    def device_of(self, key):
        """The device chunk of a ``sensor/<device>/...`` key of this user, or ``None``."""
        head = f"{self._prefix}/sensor/"
        return key[len(head):].split("/")[0] if key.startswith(head) else None

    def agent_of(self, key):
        """The agent chunk of a ``health/<agent>`` key of this user, or ``None``."""
        head = f"{self._prefix}/health/"
        return key[len(head):] if key.startswith(head) else None


#: ``cmd/<verb>`` chunk of each ``Command`` variant (messages.rs ``Command::verb``).
COMMAND_VERBS = {
    "Destination": "destination",
    "WhereAmI": "where-am-i",
    "Mute": "mute",
    "Repeat": "repeat",
    "Cancel": "cancel",
    "Floor": "floor",
    "Door": "door",
    "Place": "place",
}


def command_verb(command):
    """The verb a decoded/encodable ``Command`` value is published under."""
    variant = command if isinstance(command, str) else next(iter(command))
    return COMMAND_VERBS[variant]
