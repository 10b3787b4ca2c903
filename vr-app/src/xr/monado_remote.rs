//! A client for Monado's remote driver, for the by-hand runtime test in `xr_runtime`.
//!
//! Monado built with `XRT_BUILD_DRIVER_REMOTE=ON` and run with
//! `P_OVERRIDE_ACTIVE_CONFIG=remote` offers a headset and two Valve Index controllers
//! whose state a TCP peer sets: the driver (`drivers/remote/r_hub.c`) listens on port
//! 4242, greets each connection with two records (its reset and latest state) and then
//! takes each record it reads as the devices' new state. A record is Monado's
//! `struct r_remote_data`, native-endian and padded as C lays it out: the header, the
//! headset's pose, then the left and right controllers.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// `R_HEADER_VALUE`: "mndrmt2" and a NUL, read as a native `u64`.
const HEADER: [u8; 8] = *b"mndrmt2\0";
/// `sizeof(struct xrt_pose)`: orientation (x, y, z, w) then position.
const POSE_BYTES: usize = 7 * 4;
/// `sizeof(struct r_remote_controller_data)`: the pose, 19 floats, 16 bools.
const CONTROLLER_BYTES: usize = POSE_BYTES + 19 * 4 + 16;
/// `sizeof(struct r_remote_data)`: header, headset pose, two controllers, padded to 8.
pub const RECORD_BYTES: usize = (8 + POSE_BYTES + 2 * CONTROLLER_BYTES).next_multiple_of(8);

/// One controller's state, positions in the runtime's stage space (metres).
#[derive(Debug, Clone, Copy, Default)]
pub struct Controller {
    /// Where the controller is (its orientation is the stage's).
    pub position: [f32; 3],
    /// Trigger value, 0 to 1.
    pub trigger: f32,
    /// Thumbstick x and y, -1 to 1.
    pub thumbstick: [f32; 2],
    /// The A button is down.
    pub a_click: bool,
    /// The B button is down.
    pub b_click: bool,
}

fn put_pose(out: &mut Vec<u8>, position: [f32; 3]) {
    for v in [0.0, 0.0, 0.0, 1.0].into_iter().chain(position) {
        out.extend_from_slice(&f32::to_ne_bytes(v));
    }
}

fn put_controller(out: &mut Vec<u8>, c: &Controller) {
    let start = out.len();
    put_pose(out, c.position);
    // Linear and angular velocity, hand curl (5).
    out.extend(std::iter::repeat_n(0, 11 * 4));
    // Trigger value, squeeze value and force, thumbstick (2), trackpad force,
    // trackpad (2).
    for v in [
        c.trigger,
        0.0,
        0.0,
        c.thumbstick[0],
        c.thumbstick[1],
        0.0,
        0.0,
        0.0,
    ] {
        out.extend_from_slice(&f32::to_ne_bytes(v));
    }
    let stick_touched = c.thumbstick != [0.0, 0.0];
    let bools = [
        false, // hand tracking active
        true,  // active
        false, // system click, touch
        false,
        c.a_click,
        c.a_click,
        c.b_click,
        c.b_click,
        c.trigger > 0.9, // trigger click, touch
        c.trigger > 0.1,
        false, // thumbstick click, touch
        stick_touched,
        false, // trackpad touch, padding (3)
        false,
        false,
        false,
    ];
    out.extend(bools.map(u8::from));
    debug_assert_eq!(out.len() - start, CONTROLLER_BYTES);
}

/// One `r_remote_data` record: the headset at `head`, looking down the stage's -Z.
pub fn record(head: [f32; 3], left: &Controller, right: &Controller) -> Vec<u8> {
    let mut out = Vec::with_capacity(RECORD_BYTES);
    out.extend_from_slice(&HEADER);
    put_pose(&mut out, head);
    put_controller(&mut out, left);
    put_controller(&mut out, right);
    out.resize(RECORD_BYTES, 0);
    out
}

/// Connects to the driver at `addr` (retrying until `patience` runs out: the driver
/// starts listening when the runtime's instance is created) and reads its greeting.
pub fn connect(addr: &str, patience: Duration) -> std::io::Result<TcpStream> {
    let deadline = Instant::now() + patience;
    let mut stream = loop {
        match TcpStream::connect(addr) {
            Ok(s) => break s,
            Err(e) if Instant::now() >= deadline => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    };
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(patience))?;
    let mut greeting = vec![0; 2 * RECORD_BYTES];
    stream.read_exact(&mut greeting)?;
    Ok(stream)
}

/// Plays `script` (state as a function of the time since the start) at 100 Hz for
/// `length`.
pub fn play(
    stream: &mut TcpStream,
    length: Duration,
    script: impl Fn(f32) -> (Controller, Controller),
) -> std::io::Result<()> {
    let start = Instant::now();
    while start.elapsed() < length {
        let (left, right) = script(start.elapsed().as_secs_f32());
        stream.write_all(&record([0.0, 1.6, 0.0], &left, &right))?;
        std::thread::sleep(Duration::from_millis(10));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The record's layout is C's: Monado's 64-bit build reads 280 bytes.
    #[test]
    fn records_have_the_drivers_size_and_layout() {
        assert_eq!(CONTROLLER_BYTES, 120);
        assert_eq!(RECORD_BYTES, 280);
        let right = Controller {
            position: [0.1, 1.2, -0.4],
            trigger: 1.0,
            ..Controller::default()
        };
        let r = record([0.0, 1.6, 0.0], &Controller::default(), &right);
        assert_eq!(r.len(), RECORD_BYTES);
        assert_eq!(&r[..8], b"mndrmt2\0");
        let f = |at: usize| f32::from_ne_bytes(r[at..at + 4].try_into().unwrap());
        // Headset: w = 1, y = 1.6.
        assert_eq!((f(8 + 12), f(8 + 20)), (1.0, 1.6));
        let right_at = 8 + POSE_BYTES + CONTROLLER_BYTES;
        assert_eq!(f(right_at + 16), 0.1);
        // The trigger value follows the pose, two velocities and five curls.
        assert_eq!(f(right_at + POSE_BYTES + 11 * 4), 1.0);
        // `active` is the second bool; trigger click the ninth.
        let bools = right_at + CONTROLLER_BYTES - 16;
        assert_eq!((r[bools + 1], r[bools + 8]), (1, 1));
    }
}
