//! Wii remote HID reports, byte for byte (wiibrew "Wiimote" protocol pages; Linux
//! `drivers/hid/hid-wiimote-core.c`). On hidraw the first byte is the report id; the
//! Bluetooth `0xa2`/`0xa1` transaction header is added by the kernel and absent here.
//!
//! Bit 0 of byte 1 of **every** output report is the rumble motor: a report written
//! without it switches rumble off. So no builder here takes "the rumble state" as an
//! afterthought: each one takes `rumble` and sets the bit.

/// Nintendo's USB vendor id.
pub const VENDOR_NINTENDO: u16 = 0x057e;
/// RVL-CNT-01, the original remote.
pub const PRODUCT_RVL_CNT_01: u16 = 0x0306;
/// RVL-CNT-01-TR, the remote with MotionPlus inside.
pub const PRODUCT_RVL_CNT_01_TR: u16 = 0x0330;

/// Output report 0x10: rumble only.
pub const OUT_RUMBLE: u8 = 0x10;
/// Output report 0x11: player LEDs.
pub const OUT_LEDS: u8 = 0x11;
/// Output report 0x12: data reporting mode.
pub const OUT_REPORTING_MODE: u8 = 0x12;
/// Output report 0x15: status request (answered by input report 0x20).
pub const OUT_STATUS_REQUEST: u8 = 0x15;
/// Input report 0x20: status (buttons, flags, battery).
pub const IN_STATUS: u8 = 0x20;
/// Data reporting mode 0x30: core buttons only, the smallest stream.
pub const MODE_CORE_BUTTONS: u8 = 0x30;

/// Status flag: battery nearly empty.
pub const FLAG_BATTERY_LOW: u8 = 0x01;

fn rumble_bit(rumble: bool) -> u8 {
    rumble as u8
}

/// `10 RR`: set the rumble motor alone.
pub fn rumble_report(rumble: bool) -> [u8; 2] {
    [OUT_RUMBLE, rumble_bit(rumble)]
}

/// `11 LL`: player LEDs `1..=4` in the high nibble (LED 1 = 0x10), rumble in bit 0.
pub fn leds_report(player_leds: &[u8], rumble: bool) -> [u8; 2] {
    let leds = player_leds.iter().filter(|n| (1..=4).contains(*n)).fold(0u8, |acc, n| acc | (0x10 << (n - 1)));
    [OUT_LEDS, leds | rumble_bit(rumble)]
}

/// `12 TT MM`: report in `mode`, only on change (continuous bit 0x04 clear).
pub fn reporting_mode_report(mode: u8, rumble: bool) -> [u8; 3] {
    [OUT_REPORTING_MODE, rumble_bit(rumble), mode]
}

/// `15 RR`: ask for a status report (battery).
pub fn status_request_report(rumble: bool) -> [u8; 2] {
    [OUT_STATUS_REQUEST, rumble_bit(rumble)]
}

/// A decoded status report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// Raw battery byte.
    pub battery_raw: u8,
    /// Battery percentage as the kernel driver computes it (`raw * 100 / 255`).
    pub battery_percent: u8,
    /// The remote's own "battery nearly empty" flag.
    pub battery_low_flag: bool,
    /// Player LEDs lit (bit 0 = LED 1).
    pub leds: u8,
}

/// An input report the backend understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputReport {
    /// `20 BB BB LF 00 00 VV`.
    Status(Status),
    /// Any other report id (buttons, acknowledgements), ignored.
    Other(u8),
}

/// Why input bytes could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// Zero-length read.
    #[error("empty input report")]
    Empty,
    /// A status report shorter than its 7 bytes.
    #[error("status report of {0} bytes, expected 7")]
    ShortStatus(usize),
}

/// Decode one input report.
pub fn parse_input(bytes: &[u8]) -> Result<InputReport, InputError> {
    let (&id, _) = bytes.split_first().ok_or(InputError::Empty)?;
    if id != IN_STATUS {
        return Ok(InputReport::Other(id));
    }
    if bytes.len() < 7 {
        return Err(InputError::ShortStatus(bytes.len()));
    }
    let flags = bytes[3];
    let raw = bytes[6];
    Ok(InputReport::Status(Status {
        battery_raw: raw,
        battery_percent: (raw as u16 * 100 / 255) as u8,
        battery_low_flag: flags & FLAG_BATTERY_LOW != 0,
        leds: flags >> 4,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_output_report_carries_the_rumble_bit_in_byte_one() {
        assert_eq!(rumble_report(true), [0x10, 0x01]);
        assert_eq!(rumble_report(false), [0x10, 0x00]);
        assert_eq!(leds_report(&[1], true), [0x11, 0x11]);
        assert_eq!(leds_report(&[2], false), [0x11, 0x20]);
        assert_eq!(leds_report(&[1, 4], false), [0x11, 0x90]);
        assert_eq!(reporting_mode_report(MODE_CORE_BUTTONS, true), [0x12, 0x01, 0x30]);
        assert_eq!(status_request_report(false), [0x15, 0x00]);
        assert_eq!(status_request_report(true), [0x15, 0x01]);
    }

    #[test]
    fn status_report_yields_battery_and_low_flag() {
        // Buttons 0, flags: LED 1 lit + battery low, battery byte 0x20.
        let r = parse_input(&[0x20, 0x00, 0x00, 0x11, 0x00, 0x00, 0x20]).unwrap();
        assert_eq!(
            r,
            InputReport::Status(Status { battery_raw: 0x20, battery_percent: 12, battery_low_flag: true, leds: 1 })
        );
        let full = parse_input(&[0x20, 0, 0, 0x20, 0, 0, 0xff]).unwrap();
        assert!(matches!(full, InputReport::Status(Status { battery_percent: 100, battery_low_flag: false, .. })));
    }

    #[test]
    fn other_and_malformed_inputs_are_told_apart() {
        assert_eq!(parse_input(&[0x30, 0x00, 0x08]), Ok(InputReport::Other(0x30)));
        assert_eq!(parse_input(&[]), Err(InputError::Empty));
        assert_eq!(parse_input(&[0x20, 0, 0]), Err(InputError::ShortStatus(3)));
    }
}
