//! The kernel's force-feedback interface as plain data (`linux/input.h`,
//! Documentation/input/ff.rst): the `ff_effect` and `input_event` structs with their
//! exact 64-bit Linux layouts (x86_64, aarch64), and the ioctl numbers that carry them.
//! No file descriptor here, so every byte is testable.

/// `EV_FF`: the event type that plays and stops effects.
pub const EV_FF: u16 = 0x15;
/// `FF_RUMBLE`: the effect type of rumble motors (hid-wiimote's only one).
pub const FF_RUMBLE: u16 = 0x50;

/// `_IOW(dir=1, type, nr, size)` as asm-generic encodes it (x86 and arm64 alike).
const fn iow(kind: u8, nr: u8, size: usize) -> u64 {
    (1 << 30) | ((size as u64) << 16) | ((kind as u64) << 8) | nr as u64
}

/// `EVIOCSFF`: upload (id -1) or update (id kept) an effect; `_IOW('E', 0x80, struct ff_effect)`.
pub const EVIOCSFF: u64 = iow(b'E', 0x80, FF_EFFECT_BYTES);
/// `EVIOCRMFF`: erase an effect; `_IOW('E', 0x81, int)`, the id passed by value.
pub const EVIOCRMFF: u64 = iow(b'E', 0x81, 4);

/// `sizeof(struct ff_effect)` on 64-bit Linux.
pub const FF_EFFECT_BYTES: usize = 48;
/// `sizeof(struct input_event)` on 64-bit Linux (16-byte `timeval` first).
pub const INPUT_EVENT_BYTES: usize = 24;

/// `struct ff_effect` with its union as `ff_rumble_effect`, laid out as on 64-bit
/// Linux: the union starts at offset 16 (8-byte aligned because `ff_periodic_effect`
/// holds a pointer) and is 32 bytes long. Padding is spelled out as fields so that every
/// byte is initialised and the struct can be viewed as bytes.
#[repr(C, align(8))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FfEffect {
    /// `type`: [`FF_RUMBLE`].
    pub kind: u16,
    /// `id`: -1 to upload a new effect; the kernel writes the id it gave back here.
    pub id: i16,
    /// `direction` (unused by rumble).
    pub direction: u16,
    /// `trigger.button`.
    pub trigger_button: u16,
    /// `trigger.interval`.
    pub trigger_interval: u16,
    /// `replay.length`, ms (0 = until stopped).
    pub replay_length_ms: u16,
    /// `replay.delay`, ms.
    pub replay_delay_ms: u16,
    /// Alignment padding before the union.
    pub pad: u16,
    /// `u.rumble.strong_magnitude`.
    pub strong_magnitude: u16,
    /// `u.rumble.weak_magnitude`.
    pub weak_magnitude: u16,
    /// The rest of the union (`ff_periodic_effect` is the largest member).
    pub union_rest: [u8; 28],
}

const _: () = assert!(std::mem::size_of::<FfEffect>() == FF_EFFECT_BYTES);

impl FfEffect {
    /// A rumble effect at `magnitude` on both motors, stopping by itself after
    /// `length_ms` (the kernel's ff-memless timer, a backstop behind the agent's TTL).
    pub fn rumble(id: i16, magnitude: u16, length_ms: u16) -> Self {
        Self {
            kind: FF_RUMBLE,
            id,
            direction: 0,
            trigger_button: 0,
            trigger_interval: 0,
            replay_length_ms: length_ms,
            replay_delay_ms: 0,
            pad: 0,
            strong_magnitude: magnitude,
            weak_magnitude: magnitude,
            union_rest: [0; 28],
        }
    }

    /// The bytes the kernel reads, in memory order.
    pub fn as_bytes(&self) -> &[u8; FF_EFFECT_BYTES] {
        // SAFETY: `FfEffect` is repr(C), exactly FF_EFFECT_BYTES long (asserted above)
        // and has no implicit padding (every gap is a field), so all its bytes are
        // initialised; the returned reference borrows `self`.
        unsafe { &*(self as *const FfEffect as *const [u8; FF_EFFECT_BYTES]) }
    }
}

/// Motor magnitude for a level 0..1 (NaN and negatives are off).
pub fn magnitude(level: f32) -> u16 {
    if level > 0.0 {
        (level.min(1.0) * u16::MAX as f32).round() as u16
    } else {
        0
    }
}

/// `struct input_event { struct timeval time; __u16 type; __u16 code; __s32 value; }`
/// in native byte order, time zero (the kernel stamps events itself).
pub fn input_event(kind: u16, code: u16, value: i32) -> [u8; INPUT_EVENT_BYTES] {
    let mut b = [0u8; INPUT_EVENT_BYTES];
    b[16..18].copy_from_slice(&kind.to_ne_bytes());
    b[18..20].copy_from_slice(&code.to_ne_bytes());
    b[20..24].copy_from_slice(&value.to_ne_bytes());
    b
}

/// Play effect `id` (`value` 1 = once; the effect's own length times it).
pub fn play(id: i16) -> [u8; INPUT_EVENT_BYTES] {
    input_event(EV_FF, id as u16, 1)
}

/// Stop effect `id`.
pub fn stop(id: i16) -> [u8; INPUT_EVENT_BYTES] {
    input_event(EV_FF, id as u16, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ioctl_numbers_match_the_kernel_headers() {
        assert_eq!(EVIOCSFF, 0x4030_4580);
        assert_eq!(EVIOCRMFF, 0x4004_4581);
    }

    #[test]
    fn ff_effect_is_laid_out_as_on_64_bit_linux() {
        let e = FfEffect::rumble(-1, 0xabcd, 2000);
        assert_eq!(std::mem::align_of::<FfEffect>(), 8);
        assert_eq!(std::mem::offset_of!(FfEffect, replay_length_ms), 10);
        assert_eq!(std::mem::offset_of!(FfEffect, strong_magnitude), 16, "the union is 8-byte aligned");
        let mut want = [0u8; 48];
        want[0..2].copy_from_slice(&[0x50, 0x00]); // type FF_RUMBLE
        want[2..4].copy_from_slice(&[0xff, 0xff]); // id -1: new effect
        want[10..12].copy_from_slice(&[0xd0, 0x07]); // replay.length 2000 ms
        want[16..18].copy_from_slice(&[0xcd, 0xab]); // strong
        want[18..20].copy_from_slice(&[0xcd, 0xab]); // weak
        assert_eq!(e.as_bytes(), &want);
    }

    #[test]
    fn play_and_stop_are_ev_ff_events_with_the_effect_id() {
        let mut want = [0u8; 24];
        want[16..24].copy_from_slice(&[0x15, 0x00, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00]);
        assert_eq!(play(3), want);
        want[20] = 0;
        assert_eq!(stop(3), want);
    }

    #[test]
    fn levels_become_full_scale_magnitudes() {
        assert_eq!(magnitude(1.0), 0xffff);
        assert_eq!(magnitude(0.5), 0x8000);
        assert_eq!(magnitude(0.0), 0);
        assert_eq!(magnitude(f32::NAN), 0);
        assert_eq!(magnitude(7.0), 0xffff);
    }
}
