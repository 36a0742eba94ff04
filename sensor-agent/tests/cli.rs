//! The sensor agent's command line: what it refuses before it opens the bus.

use std::process::Command;

/// Runs the agent; whether it succeeded, and what it wrote to stderr.
fn run(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sensor-agent"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("the sensor agent runs");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn an_imu_is_taken_for_a_real_camera_only_and_its_axes_only_with_it() {
    // the simulator's frames carry the simulated IMU's: a second one would be mixed in
    let (ok, err) = run(&["--source", "sim:approach", "--imu", "mpu6050:/dev/i2c-1"]);
    assert!(!ok && err.contains("--imu is for a real camera (openni2:); \"sim:approach\""), "{err}");
    let (ok, err) = run(&["--imu-axes", "-y,-z,x"]);
    assert!(!ok && err.contains("--imu <SPEC>"), "{err}");
    // the axes as the README writes them (a leading minus is a value, not a flag),
    // checked before any device is opened
    let (ok, err) = run(&["--source", "sim:approach", "--imu", "mpu6050:/dev/i2c-1", "--imu-axes", "-y,-z,x"]);
    assert!(!ok && err.contains("--imu is for a real camera"), "{err}");
}

#[test]
fn a_barometer_is_taken_for_a_real_camera_only() {
    // the simulator's frames carry the simulated cane board's pressure
    let (ok, err) = run(&["--source", "sim:approach", "--barometer", "bmp388:/dev/i2c-1"]);
    assert!(!ok && err.contains("--barometer is for a real camera's cane board (openni2:); \"sim:approach\""), "{err}");
}
