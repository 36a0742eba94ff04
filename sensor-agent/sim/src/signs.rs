//! A door-sign reader, simulated: a chest-worn camera that reads the number on a
//! door's sign as the user walks past, and where the sign is (Zhang et al. read door
//! numbers with the user's "verify door number"; a reader that reads every sign in
//! view is the same landmark, more often). What it reads goes to the localization
//! filter as a `Door` landmark in the body frame.
//!
//! A sign is read when it is on the user's floor, within [`SignReaderConfig::range_m`],
//! within [`SignReaderConfig::half_fov_deg`] of the body's heading, seen from its front
//! (within [`SignReaderConfig::max_incidence_deg`] of its face's normal) and nothing of
//! the world (walls, furniture, people) is between the reader and the sign. It is read
//! once each time it comes into view, not at every frame; it must leave view (out of
//! range by a metre, or behind) before it is read again.
//!
//! The reading's place has Gaussian noise per body axis; with
//! [`SignReaderConfig::misread_probability`] the number is another door's of the world
//! (the harmful misread: a number the map has, somewhere else), and
//! [`DoorSignReader::misread_next`] forces one (the injected misread).

use crate::random::SimRng;
use crate::world::{UserPose, World};

/// What the reader can read, and how well.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignReaderConfig {
    /// Farthest sign it reads, metres (a door sign's 2-3 cm digits at a phone
    /// camera's resolution).
    pub range_m: f64,
    /// Half the reader's field of view about the body's heading, degrees.
    pub half_fov_deg: f64,
    /// Largest angle between the sign's normal and the line to the reader, degrees.
    pub max_incidence_deg: f64,
    /// Height of the reader and of the signs above the floor, metres (the line of
    /// sight tested against the world).
    pub height_m: f64,
    /// Standard deviation of the sign's measured place, per body axis, metres.
    pub position_sigma_m: f64,
    /// Probability that a reading is another door's number.
    pub misread_probability: f64,
}

impl Default for SignReaderConfig {
    /// 3 m, ±35°, 70° off the sign's normal at most, 1.4 m high, 0.15 m, 2 % misread.
    fn default() -> Self {
        Self {
            range_m: 3.0,
            half_fov_deg: 35.0,
            max_incidence_deg: 70.0,
            height_m: 1.4,
            position_sigma_m: 0.15,
            misread_probability: 0.02,
        }
    }
}

/// One sign read.
#[derive(Debug, Clone, PartialEq)]
pub struct SignReading {
    /// The number read (another door's when misread).
    pub number: String,
    /// Where the sign was seen, metres ahead of the body.
    pub forward_m: f64,
    /// ... and to its left.
    pub left_m: f64,
    /// The door whose sign it was (index into [`World::doors`]): for tests and monitors.
    pub door: usize,
    /// Whether the number is not that door's: for tests and monitors.
    pub misread: bool,
}

/// The reader, its randomness, and which signs are in view.
#[derive(Debug, Clone)]
pub struct DoorSignReader {
    config: SignReaderConfig,
    rng: SimRng,
    /// per door of the world: read and not yet out of view again
    in_view: Vec<bool>,
    misread_next: bool,
}

impl DoorSignReader {
    /// A reader for `world`'s doors.
    pub fn new(config: SignReaderConfig, world: &World, rng: SimRng) -> Self {
        Self { config, rng, in_view: vec![false; world.doors().len()], misread_next: false }
    }

    /// The next reading will be a misread (when the world has another door's number).
    pub fn misread_next(&mut self) {
        self.misread_next = true;
    }

    /// The signs that came into view at `body` and time `t_s` (each once per time it
    /// comes into view), nearest first.
    pub fn read(&mut self, world: &World, body: &UserPose, t_s: f64) -> Vec<SignReading> {
        let c = self.config;
        let (s, co) = body.yaw_rad.sin_cos();
        let mut seen = Vec::new();
        for (i, door) in world.doors().iter().enumerate() {
            let (dx, dy) = (door.at[0] - body.x_m, door.at[1] - body.y_m);
            let (forward, left) = (co * dx + s * dy, -s * dx + co * dy);
            let distance = dx.hypot(dy);
            if door.floor != body.floor || forward < 0.0 || distance > c.range_m + 1.0 {
                self.in_view[i] = false;
                continue;
            }
            if self.in_view[i] || distance > c.range_m || left.atan2(forward).abs() > c.half_fov_deg.to_radians() {
                continue;
            }
            let (fs, fc) = door.facing_deg.to_radians().sin_cos();
            // cosine of the angle between the sign's normal and the line to the reader
            let incidence = -(fc * dx + fs * dy) / distance.max(1e-9);
            if incidence < c.max_incidence_deg.to_radians().cos() {
                continue;
            }
            // the line of sight, to just in front of the wall the sign is on
            let sign = [door.at[0] + 0.15 * fc, door.at[1] + 0.15 * fs, c.height_m];
            let eye = [body.x_m, body.y_m, c.height_m];
            if world.nearest_to_segment(body.floor, eye, sign, t_s).is_some_and(|n| n.distance_m < 0.01) {
                continue;
            }
            self.in_view[i] = true;
            seen.push((distance, i, forward, left));
        }
        seen.sort_by(|a, b| a.0.total_cmp(&b.0));
        seen.into_iter()
            .map(|(_, i, forward, left)| {
                let others: Vec<usize> =
                    (0..world.doors().len()).filter(|&j| world.doors()[j].number != world.doors()[i].number).collect();
                let misread = !others.is_empty()
                    && (std::mem::take(&mut self.misread_next) || self.rng.uniform() < c.misread_probability);
                let number = if misread {
                    let j = others[((self.rng.uniform() * others.len() as f64) as usize).min(others.len() - 1)];
                    world.doors()[j].number.clone()
                } else {
                    world.doors()[i].number.clone()
                };
                SignReading {
                    number,
                    forward_m: forward + c.position_sigma_m * self.rng.gaussian(),
                    left_m: left + c.position_sigma_m * self.rng.gaussian(),
                    door: i,
                    misread,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A corridor along +x, walls at y = 0 and y = 2, doors on the south wall facing
    /// north at x = 3 ("101") and x = 8 ("102"), one on the north wall facing south at
    /// x = 5 ("103"), a box between the walker and door 102 when `blocked`.
    fn corridor(blocked: bool) -> World {
        let block = if blocked {
            "[[boxes]]\ncenter = [6.5, 0.5]\nsize_m = [0.4, 0.6]\nbottom_m = 0.0\ntop_m = 2.0\n"
        } else {
            ""
        };
        let text = format!(
            "name = \"signs\"\nstart = {{ x_m = 0.0, y_m = 1.0, yaw_deg = 0.0 }}\ngoal = {{ x_m = 10.0, y_m = 1.0 }}\n\
             [[walls]]\nfrom = [-1.0, 0.0]\nto = [12.0, 0.0]\n[[walls]]\nfrom = [-1.0, 2.0]\nto = [12.0, 2.0]\n\
             [[doors]]\nnumber = \"101\"\nat = [3.0, 0.0]\nfacing_deg = 90.0\n\
             [[doors]]\nnumber = \"102\"\nat = [8.0, 0.0]\nfacing_deg = 90.0\n\
             [[doors]]\nnumber = \"103\"\nat = [5.0, 2.0]\nfacing_deg = -90.0\n{block}"
        );
        World::from_toml(&text, "test").unwrap_or_else(|e| panic!("{e}"))
    }

    fn walk(world: &World, config: SignReaderConfig, seed: u64) -> Vec<(f64, SignReading)> {
        let mut reader = DoorSignReader::new(config, world, SimRng::seed_from(seed));
        let mut out = Vec::new();
        for k in 0..=100 {
            let x = k as f64 * 0.1;
            let body = UserPose { x_m: x, y_m: 1.0, yaw_rad: 0.0, floor: 0 };
            out.extend(reader.read(world, &body, 0.0).into_iter().map(|r| (x, r)));
        }
        out
    }

    #[test]
    fn each_sign_is_read_once_as_it_comes_into_view_where_it_is() {
        let exact = SignReaderConfig { position_sigma_m: 0.0, misread_probability: 0.0, ..Default::default() };
        let world = corridor(false);
        let read = walk(&world, exact, 1);
        let numbers: Vec<&str> = read.iter().map(|(_, r)| r.number.as_str()).collect();
        assert_eq!(numbers, ["101", "103", "102"]);
        for (x, r) in &read {
            let door = &world.doors()[r.door];
            // read at the edge of the range (3 m), where it is, in the body frame
            let d = r.forward_m.hypot(r.left_m);
            assert!(d <= 3.0 && d > 2.85, "{} read at {d} m", r.number);
            assert!((r.forward_m - (door.at[0] - x)).abs() < 1e-9 && (r.left_m - (door.at[1] - 1.0)).abs() < 1e-9);
            assert!(!r.misread);
        }
    }

    #[test]
    fn a_sign_behind_a_box_is_not_read_until_it_is_in_sight() {
        let exact = SignReaderConfig { position_sigma_m: 0.0, misread_probability: 0.0, ..Default::default() };
        let read = walk(&corridor(true), exact, 1);
        let (x, r) = read.iter().find(|(_, r)| r.number == "102").expect("102 read at last");
        // unblocked it is read at 3 m, from x = 5.2; the box at x = 6.3-6.7 hides it
        // until the walker is past the line through the box's corner
        assert!(*x > 5.5, "read through the box from x = {x}");
        assert!(r.forward_m > 0.0);
    }

    #[test]
    fn misreads_give_another_door_of_the_world_and_can_be_forced() {
        let w = corridor(false);
        let mut reader = DoorSignReader::new(
            SignReaderConfig { misread_probability: 0.0, ..Default::default() },
            &w,
            SimRng::seed_from(3),
        );
        reader.misread_next();
        let body = UserPose { x_m: 0.5, y_m: 1.0, yaw_rad: 0.0, floor: 0 };
        let r = reader.read(&w, &body, 0.0);
        assert_eq!(r.len(), 1);
        assert!(r[0].misread && r[0].number != "101" && ["102", "103"].contains(&r[0].number.as_str()));
        // at a 30 % misread rate over many walks, about 30 % are misread
        let noisy = SignReaderConfig { misread_probability: 0.3, ..Default::default() };
        let all: Vec<SignReading> = (0..200).flat_map(|s| walk(&w, noisy, s)).map(|(_, r)| r).collect();
        let share = all.iter().filter(|r| r.misread).count() as f64 / all.len() as f64;
        assert!((share - 0.3).abs() < 0.05, "{share}");
        assert!(all.iter().all(|r| r.misread == (r.number != w.doors()[r.door].number)));
    }
}
